"""RIHS01 type hashes (ROS 2 type description hashes, REP 2011) from ``ros2msg`` text.

rosbag2 writes each topic's ``type_description_hash`` into ``metadata.yaml``; rosidl
computes it when it builds a type: SHA-256 of the JSON type description — the type's
fields (name, type id, array capacity, string bound, nested type name) and, sorted by
name, those of every type it refers to; constants and default values are not part of
it. Here it is computed from a recording's own schema (an MCAP ``ros2msg`` schema: the
type's ``.msg`` text, then each dependency behind a line of ``=`` and ``MSG: pkg/Type``),
so no ROS installation is needed. ``tests/unit/test_record_typehash.py`` holds it to the
hashes ``rosbags`` computes for ROS 2 Kilted's types and to those rosidl wrote when it
built the interface packages.
"""

from __future__ import annotations

import hashlib
import json
import re

__all__ = ["rihs01"]

# rosidl's FieldType ids (type_description_interfaces/msg/FieldType.msg)
_TYPE_IDS = {"nested": 1, "int8": 2, "uint8": 3, "int16": 4, "uint16": 5, "int32": 6,
             "uint32": 7, "int64": 8, "uint64": 9, "float32": 10, "float64": 11,
             "float128": 12, "char": 13, "wchar": 14, "bool": 15, "byte": 16, "string": 17,
             "wstring": 18, "bounded_string": 21, "bounded_wstring": 22}
_ARRAY, _BOUNDED_SEQUENCE, _UNBOUNDED_SEQUENCE = 48, 96, 144
_FIELD = re.compile(r"^(?P<base>[A-Za-z][\w/]*)(?:<=(?P<strbound>\d+))?"
                    r"(?:\[(?P<seq><=)?(?P<size>\d*)\])?$")
_SEPARATOR = re.compile(r"^={80}\s*$", re.MULTILINE)


def _full_name(name: str, package: str) -> str:
    if name == "Header":
        return "std_msgs/msg/Header"
    parts = name.split("/")
    if len(parts) == 1:
        return f"{package}/msg/{name}"
    return f"{parts[0]}/msg/{parts[-1]}"


def _fields(text: str, package: str) -> list[dict]:
    """The type-description fields of one ``.msg`` text (constants skipped)."""
    fields = []
    for raw in text.splitlines():
        line = raw.split("#", 1)[0].strip()
        if not line:
            continue
        ftype, rest = line.split(None, 1)
        name = rest.split(None, 1)[0]
        if "=" in name or rest.lstrip().startswith("="):  # a constant: NAME=value
            continue
        match = _FIELD.match(ftype)
        if match is None:
            raise ValueError(f"bad field type {ftype!r} in {line!r}")
        base, size = match["base"], match["size"]
        nested = ""
        if base in _TYPE_IDS and base != "nested":
            type_id = _TYPE_IDS["bounded_" + base if match["strbound"] else base]
        else:
            type_id, nested = _TYPE_IDS["nested"], _full_name(base, package)
        capacity = 0
        if "[" in ftype:
            if match["seq"]:
                type_id, capacity = type_id + _BOUNDED_SEQUENCE, int(size)
            elif size:
                type_id, capacity = type_id + _ARRAY, int(size)
            else:
                type_id += _UNBOUNDED_SEQUENCE
        fields.append({"name": name, "type": {
            "type_id": type_id, "capacity": capacity,
            "string_capacity": int(match["strbound"] or 0), "nested_type_name": nested}})
    return fields or [{"name": "structure_needs_at_least_one_member", "type": {
        "type_id": _TYPE_IDS["uint8"], "capacity": 0, "string_capacity": 0,
        "nested_type_name": ""}}]


def rihs01(type_name: str, schema: str) -> str:
    """``RIHS01_<sha256 hex>`` of ``type_name`` (``pkg/msg/Type``) whose concatenated
    ``ros2msg`` text (the type and every dependency) is ``schema``. ValueError when a
    referenced type is not in the text."""
    sections = _SEPARATOR.split(schema)
    texts = {type_name: sections[0]}
    for section in sections[1:]:
        header, _, body = section.lstrip("\n").partition("\n")
        if not header.startswith("MSG: "):
            raise ValueError(f"{type_name}: schema section without a MSG: line")
        dep = header[5:].strip()
        texts[_full_name(dep, dep.split("/")[0])] = body
    described: dict[str, dict] = {}

    def describe(name: str) -> None:
        if name in described:
            return
        if name not in texts:
            raise ValueError(f"{type_name}: the schema lacks {name}")
        fields = _fields(texts[name], name.split("/")[0])
        described[name] = {"type_name": name, "fields": fields}
        for field in fields:
            if field["type"]["nested_type_name"]:
                describe(field["type"]["nested_type_name"])

    describe(type_name)
    description = {
        "type_description": described[type_name],
        "referenced_type_descriptions": [described[n] for n in sorted(described)
                                         if n != type_name],
    }
    return "RIHS01_" + hashlib.sha256(json.dumps(description).encode()).hexdigest()
