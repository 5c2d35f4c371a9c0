#!/usr/bin/env python3
"""Interoperability peer for mil-frames: decodes and encodes frames with cantools.

Usage: cantools_peer.py DBC REQUEST.json   (prints one JSON object on stdout)

Request:
  {"decode": [{"id": 259, "data": "20a107c0bdf007"}, ...],
   "encode": [{"message": "Measurement_Ch3", "signals": {"Position": 0.5, ...},
               "scaling": true, "strict": true}, ...]}
Reply:
  {"cantools": "45.1.0",
   "decoded": [{"id": 259, "name": "Measurement_Ch3", "signals": {...}, "raw": {...}}
               | {"id": ..., "error": "..."}],
   "encoded": [{"message": ..., "id": 259, "data": "hex"} | {"message": ..., "error": "..."}]}

Non-finite floats travel as the strings "nan", "inf", "-inf" (JSON has no NaN).
Decoding uses decode_choices=False (numbers, not value-table names).
"""

import json
import math
import sys

import cantools


def to_json(v):
    if isinstance(v, float) and not math.isfinite(v):
        return "nan" if math.isnan(v) else ("inf" if v > 0 else "-inf")
    return v


def from_json(v):
    if isinstance(v, str):
        return float(v)
    return v


def main():
    db = cantools.database.load_file(sys.argv[1])
    with open(sys.argv[2]) as f:
        request = json.load(f)

    decoded = []
    for item in request.get("decode", []):
        data = bytes.fromhex(item["data"])
        try:
            msg = db.get_message_by_frame_id(item["id"])
            scaled = msg.decode(data, decode_choices=False, scaling=True)
            raw = msg.decode(data, decode_choices=False, scaling=False)
            decoded.append({
                "id": item["id"],
                "name": msg.name,
                "signals": {k: to_json(v) for k, v in scaled.items()},
                "raw": {k: to_json(v) for k, v in raw.items()},
            })
        except Exception as e:  # reported to the Rust side, which fails the test
            decoded.append({"id": item["id"], "error": repr(e)})

    encoded = []
    for item in request.get("encode", []):
        try:
            msg = db.get_message_by_name(item["message"])
            signals = {k: from_json(v) for k, v in item["signals"].items()}
            data = msg.encode(signals, scaling=item.get("scaling", True),
                              strict=item.get("strict", True))
            encoded.append({"message": msg.name, "id": msg.frame_id, "data": data.hex()})
        except Exception as e:
            encoded.append({"message": item["message"], "error": repr(e)})

    json.dump({"cantools": cantools.__version__, "decoded": decoded, "encoded": encoded},
              sys.stdout)


if __name__ == "__main__":
    main()
