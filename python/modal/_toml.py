"""A dict (as a TOML document) → TOML text, for modal.load(dict).

The order of the dict's keys is kept (a scene's parameters are listed, and
may refer to each other, in file order). Sub-dicts become [tables] and lists
of dicts [[arrays of tables]], as a scene file writes them; dicts inside other
lists become inline tables. Values: str, bool, int, float (nan, inf), and
anything with .tolist() (numpy arrays and scalars), lists and tuples of them.
"""

import math
import numbers
import re

_BARE_KEY = re.compile(r"^[A-Za-z0-9_-]+$")


def _key(key):
    if not isinstance(key, str):
        raise TypeError(f"a scene's keys are strings, got {key!r}")
    return key if _BARE_KEY.match(key) else _string(key)


def _string(text):
    out = ['"']
    for ch in text:
        code = ord(ch)
        if ch == '"':
            out.append('\\"')
        elif ch == "\\":
            out.append("\\\\")
        elif ch == "\n":
            out.append("\\n")
        elif ch == "\t":
            out.append("\\t")
        elif code < 0x20 or code == 0x7F:
            out.append(f"\\u{code:04X}")
        elif 0xD800 <= code <= 0xDFFF:
            raise ValueError(f"a string of the scene holds a lone surrogate (U+{code:04X}): {text!r}")
        else:
            out.append(ch)
    out.append('"')
    return "".join(out)


def _plain(value):
    """numpy arrays and scalars → Python lists and numbers."""
    if hasattr(value, "tolist") and not isinstance(value, (str, bytes)):
        return value.tolist()
    return value


def _is_table(value):
    return isinstance(value, dict)


def _is_table_array(value):
    value = _plain(value)
    return isinstance(value, (list, tuple)) and len(value) > 0 and all(_is_table(v) for v in value)


def _value(value, where):
    value = _plain(value)
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, numbers.Integral):
        return str(int(value))
    if isinstance(value, numbers.Real):
        x = float(value)
        if math.isnan(x):
            return "nan"
        if math.isinf(x):
            return "inf" if x > 0 else "-inf"
        text = repr(x)  # shortest round trip; always has '.', 'e', or is e.g. '1e+20'
        return text if any(c in text for c in ".eE") else text + ".0"
    if isinstance(value, str):
        return _string(value)
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_value(v, where) for v in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{_key(k)} = {_value(v, where + '.' + str(k))}" for k, v in value.items()) + "}"
    raise TypeError(f"{where}: cannot write {type(value).__name__} {value!r} to a scene "
                    "(numbers, strings, booleans, lists and dicts only)")


def _table(lines, path, table):
    """Writes the key = value lines of `table`, then its sub-tables."""
    later = []
    for key, value in table.items():
        name = str(key)
        if _is_table(value):
            later.append(("table", key, value))
        elif _is_table_array(value):
            later.append(("array", key, _plain(value)))
        else:
            lines.append(f"{_key(key)} = {_value(value, '.'.join(path + [name]))}")
    for kind, key, value in later:
        header = ".".join(_key(k) for k in path + [key])
        if kind == "table":
            lines.append("")
            lines.append(f"[{header}]")
            _table(lines, path + [key], value)
        else:
            for item in value:
                lines.append("")
                lines.append(f"[[{header}]]")
                _table(lines, path + [key], item)


def dumps(document):
    """The TOML text of a dict (see the module's description)."""
    if not isinstance(document, dict):
        raise TypeError(f"a scene is a dict, got {type(document).__name__}")
    lines = []
    _table(lines, [], document)
    return "\n".join(lines) + "\n"
