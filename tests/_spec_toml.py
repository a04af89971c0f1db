"""A minimal TOML writer for the study-spec dicts of the tests (tomllib reads, nothing writes)."""


def _toml(d, prefix=""):
    """Minimal TOML writer for the spec dicts of these tests."""
    lines, tables = [], []
    for k, v in d.items():
        if isinstance(v, dict):
            tables.append((k, v))
        elif isinstance(v, list) and v and isinstance(v[0], dict):
            tables.append((k, v))
        else:
            lines.append(f"{k} = {_val(v)}")
    out = "\n".join(lines) + "\n"
    for k, v in tables:
        name = f"{prefix}{k}"
        if isinstance(v, list):
            for item in v:
                out += f"\n[[{name}]]\n" + _toml(item, name + ".")
        else:
            sub = {a: b for a, b in v.items() if not isinstance(b, dict)}
            out += f"\n[{name}]\n" + _toml(sub)
            for a, b in v.items():
                if isinstance(b, dict):
                    out += f"\n[{name}.{a}]\n" + _toml(b)
    return out


def _val(v):
    if isinstance(v, str):
        return f'"{v}"'
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, list):
        return "[" + ", ".join(_val(x) for x in v) + "]"
    return repr(v)
