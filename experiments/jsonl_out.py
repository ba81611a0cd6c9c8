"""The experiments' one output convention: a record printed as a JSON line, and appended to a
JSON-lines file when one is given (``--out``). Not a script."""

from __future__ import annotations

import json


def emit(record: dict, out=None, *, shown: dict | None = None) -> None:
    """Print ``shown`` (default: ``record``) as one JSON line; append ``record`` to ``out`` if given."""
    print(json.dumps(record if shown is None else shown), flush=True)
    if out:
        with open(out, "a") as f:
            f.write(json.dumps(record) + "\n")
