"""Run an experiment's child process on ``n`` forced CPU devices and read its result. Not a script.

The forced devices (``XLA_FLAGS=--xla_force_host_platform_device_count=n``) exist only if the flag
is set before JAX starts, hence a child process per device count; the child prints its record as
one line ``RESULT {json}``."""

from __future__ import annotations

import json
import os
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def run_child(script: str, args: list[str], n_devices: int) -> dict:
    """``python script --child *args`` on ``n_devices`` forced CPU devices: its ``RESULT`` record,
    or ``{"devices": n, "error": <stderr tail>}`` when it printed none."""
    env = dict(os.environ, XLA_FLAGS=f"--xla_force_host_platform_device_count={n_devices}", JAX_PLATFORMS="cpu")
    proc = subprocess.run([sys.executable, script, "--child", *args], capture_output=True, text=True, env=env, cwd=ROOT)
    lines = [ln for ln in proc.stdout.splitlines() if ln.startswith("RESULT ")]
    if not lines:
        return dict(devices=n_devices, error=proc.stderr[-800:])
    return json.loads(lines[-1][len("RESULT "):])


def parse(ap, child):
    """Add ``--out`` and the hidden ``--child`` to ``ap`` and parse; in a child process run
    ``child(args)`` and return None, else return the arguments."""
    import argparse

    ap.add_argument("--out")
    ap.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        child(args)
        return None
    return args
