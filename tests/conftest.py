"""pytest configuration: the hypothesis profile (tests/_profiles.py; default ``ci``, derandomized)."""
import _profiles

_profiles.load()
