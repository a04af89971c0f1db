"""The registry of corrections, saved with the scene in ``O.tags``, and the fingerprints of sphere sets.

Every correction is recorded in ``O.tags["clumpprops.corrections*"]`` (a header and chunks of
entries) with a fingerprint of its spheres; :func:`clumpprops.yade.check` compares the scene with it.
"""
from __future__ import annotations

import hashlib
import os
import struct

import numpy as np

from ._loader import ClumpAdapterError, _Y

_blake2b = hashlib.blake2b

# Format 2 (this version): O.tags["clumpprops.corrections"] holds one header line
#     "#clumpprops registry v2 chunks=<n> token=<t>"
# and O.tags["clumpprops.corrections.<i>"] (i < n) hold the entries, at most _CHUNK each, one line
#     "<clump id> <correction id> <fingerprint> <method>"
# A build rewrites only the chunks it touched and the header: the cost of recording one clump does
# not grow with the number of clumps in the scene (format 1 rewrote every entry on every call).
# The header's token changes with every write, so comparing it with the cached one tells whether the
# scene (O.load, O.loadTmp, O.reset, another scene) still holds what this process last wrote.
# Format 1: the entries themselves in O.tags["clumpprops.corrections"]; read as such and
# rewritten as format 2 on the next write.  Fingerprints carry their scheme: "b2:<16 hex>" (blake2b of
# the sphere records, format 2) or 16 hex digits (sha1 of their text, format 1).

_TAG = "clumpprops.corrections"
_HEADER = "#clumpprops registry v2"
_CHUNK = 256
_token = [os.urandom(6).hex(), 0]  # this process, and its count of writes: the header's token


class _Registry(dict):
    """{clump id: (correction id, fingerprint, method)} with its O.tags layout: the chunk of each
    entry, each chunk's entry lines and text, and which chunks must be written back."""

    def __init__(self):
        super().__init__()
        self.chunk_of = {}  # clump id -> chunk index
        self.chunks = []  # per chunk: {clump id: line}
        self.texts = []  # per chunk: its text as last written, or None (to be joined)
        self.tails = []  # per chunk: lines appended since (texts[k] + "".join(tails[k]) is current)
        self.dirty = set()  # chunks to write
        self.header = ""  # the header this object matches in O.tags
        self.changed = False  # mutated since read or written

    def _new_chunk(self):
        self.chunks.append({})
        self.texts.append("")
        self.tails.append([])
        return len(self.chunks) - 1

    def __setitem__(self, cid, rec):
        line = f"{cid} {rec[0]} {rec[1]} {rec[2]}\n"
        k = self.chunk_of.get(cid)
        if k is None:
            k = len(self.chunks) - 1
            if k < 0 or len(self.chunks[k]) >= _CHUNK:
                k = self._new_chunk()
            self.chunk_of[cid] = k
            if self.texts[k] is not None:
                self.tails[k].append(line)
        else:
            self.texts[k] = None
        self.chunks[k][cid] = line
        super().__setitem__(cid, rec)
        self.dirty.add(k)
        self.changed = True

    def set_many(self, cids, corr_ids, fps, method):
        """``self[cid] = (corr_id, fp, method)`` for many clumps; new ids (a build's) in bulk, chunk
        by chunk, ids already present (a reused id) one by one."""
        known = self.chunk_of
        if any(cid in known for cid in cids):
            for cid, corr_id, fp in zip(cids, corr_ids, fps):
                self[cid] = (corr_id, fp, method)
            return
        recs = [(c, f, method) for c, f in zip(corr_ids, fps)]
        lines = [f"{cid} {c} {f} {method}\n" for cid, c, f in zip(cids, corr_ids, fps)]
        dict.update(self, zip(cids, recs))
        a, n = 0, len(cids)
        while a < n:
            k = len(self.chunks) - 1
            if k < 0 or len(self.chunks[k]) >= _CHUNK:
                k = self._new_chunk()
            b = min(n, a + _CHUNK - len(self.chunks[k]))
            self.chunks[k].update(zip(cids[a:b], lines[a:b]))
            known.update(dict.fromkeys(cids[a:b], k))
            if self.texts[k] is not None:
                self.tails[k].extend(lines[a:b])
            self.dirty.add(k)
            a = b
        self.changed = True

    def pop(self, cid, *default):
        k = self.chunk_of.pop(cid, None)
        if k is not None:
            del self.chunks[k][cid]
            self.texts[k] = None
            self.dirty.add(k)
            self.changed = True
        return super().pop(cid, *default)

    def text(self, k):
        t = self.texts[k]
        if t is None:
            t = "".join(self.chunks[k].values())
        elif self.tails[k]:
            t += "".join(self.tails[k])
        self.texts[k] = t
        self.tails[k] = []
        return t

    def _add_parsed(self, text, k, what):
        for n, line in enumerate(text.splitlines(), 1):
            f = line.split()
            if not f or line.startswith("#"):
                continue
            if len(f) != 4:
                raise ClumpAdapterError(
                    f"the clumpprops registry in O.tags[{what!r}] is damaged (line {n}: {line!r}); "
                    "run cy.correct_all_clumps() to rebuild it"
                )
            cid = int(f[0])
            dict.__setitem__(self, cid, (int(f[1]), f[2], f[3]))
            self.chunk_of[cid] = k
            self.chunks[k][cid] = line + "\n"

    @classmethod
    def parse(cls, Y, head):
        """The registry of the current scene, whose header tag reads ``head``."""
        reg = cls()
        reg.header = head
        tags = Y.O.tags
        if head.startswith(_HEADER):
            fields = dict(f.split("=", 1) for f in head.split()[3:] if "=" in f)
            for k in range(int(fields.get("chunks", 0))):
                key = f"{_TAG}.{k}"
                try:
                    text = tags[key]
                except KeyError:
                    raise ClumpAdapterError(
                        f"the clumpprops registry in O.tags is damaged: {key!r} is missing; "
                        "run cy.correct_all_clumps() to rebuild it"
                    ) from None
                reg._add_parsed(text, reg._new_chunk(), key)
                reg.texts[k] = text
        elif head.startswith("#clumpprops registry"):
            raise ClumpAdapterError(
                f"the clumpprops registry in O.tags has an unknown format ({head.split(chr(10))[0]!r}): "
                "the scene was saved by a newer clumpprops"
            )
        elif head:  # format 1: every entry in the one tag; rewritten as format 2 on the next write
            old = _Registry()
            old._add_parsed(head, old._new_chunk(), _TAG)
            for cid, rec in old.items():
                reg[cid] = rec
            reg.changed = False
        return reg


_cache = {"reg": _Registry()}


def _registry():
    """The scene's registry, parsed from ``O.tags`` (cached while the header is the one last seen).

    Returns the cached object itself: mutate it and call :func:`_save_registry`."""
    Y = _Y.load()
    tags = Y.O.tags
    try:
        head = tags[_TAG]
    except KeyError:
        head = ""
    reg = _cache["reg"]
    if head != reg.header or reg.changed:
        reg = _cache["reg"] = _Registry.parse(Y, head)
    return reg


def _save_registry(reg):
    """Write the chunks ``reg`` changed and a new header to ``O.tags``."""
    Y = _Y.load()
    tags = Y.O.tags
    for k in sorted(reg.dirty):
        tags[f"{_TAG}.{k}"] = reg.text(k)
    _token[1] += 1
    head = f"{_HEADER} chunks={len(reg.chunks)} token={_token[0]}.{_token[1]}\n"
    tags[_TAG] = head
    reg.header = head
    reg.dirty.clear()
    reg.changed = False
    _cache["reg"] = reg


def _forget_registry(Y):
    """Empty the scene's registry (after ``O.bodies.clear()`` / ``replace()``: every clump is gone)."""
    tags = Y.O.tags
    for k in range(len(_registry().chunks)):
        try:
            del tags[f"{_TAG}.{k}"]
        except (KeyError, TypeError, AttributeError):
            tags[f"{_TAG}.{k}"] = ""
    _save_registry(_Registry())


_FP_RECORD = np.dtype([("id", "<i8"), ("radius", "<f8"), ("density", "<f8")])


def _fp(ids, radii, rhos):
    """Fingerprint (format 2) of a sphere set: blake2b (8 bytes) of its (id, radius, density) records,
    little-endian int64 and float64, sorted by id; written "b2:<16 hex digits>"."""
    recs = zip(ids, radii, rhos)
    if any(a > b for a, b in zip(ids, ids[1:])):
        recs = sorted(recs)
    return "b2:" + _blake2b(struct.pack("<" + "qdd" * len(ids), *[v for rec in recs for v in rec]),
                            digest_size=8).hexdigest()


def _fps(ids, radii, rhos, counts):
    """:func:`_fp` of many sphere sets at once: flat (S,) ids, radii, densities and the (M,) counts."""
    counts = np.asarray(counts)
    rec = np.empty(len(ids), _FP_RECORD)
    rec["id"], rec["radius"], rec["density"] = ids, radii, rhos
    rec = rec[np.lexsort((rec["id"], np.repeat(np.arange(len(counts)), counts)))]  # by id within each set
    buf = memoryview(rec.tobytes())
    ends = (np.cumsum(counts) * _FP_RECORD.itemsize).tolist()
    out, a = [], 0
    for e in ends:
        out.append("b2:" + _blake2b(buf[a:e], digest_size=8).hexdigest())
        a = e
    return out


def _fingerprint(spheres):
    """Identity of a clump's sphere set: ids, radii, densities (not positions: the clump moves)."""
    return _fp([b.id for b in spheres], [float(b.shape.radius) for b in spheres],
               [float(b.material.density) for b in spheres])


def _fingerprint_v1(spheres):
    """The format-1 fingerprint (scenes saved in format 1): sha1 of the spheres' text."""
    h = hashlib.sha1()
    for b in sorted(spheres, key=lambda b: b.id):
        h.update(f"{b.id}:{float(b.shape.radius).hex()}:{float(b.material.density).hex()};".encode())
    return h.hexdigest()[:16]


def _fingerprint_matches(fp, spheres):
    return fp == (_fingerprint(spheres) if fp.startswith("b2:") else _fingerprint_v1(spheres))

