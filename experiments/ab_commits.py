"""Two (or more) commits of rockjax timed by one benchmark script, alternated in fresh processes.

A code change that cannot be switched on and off inside one process (a new state layout, say) is
timed this way: each commit is checked out into a git worktree (``--worktrees``, default
``/tmp/rockjax_ab``) and the benchmark script of *this* checkout runs against that commit's
``src`` (``PYTHONPATH``), commit after commit, ``--repeats`` rounds, so that a slow spell of the
shared machine hits all alike. Every JSON line the script prints is re-emitted with ``commit`` and
``round`` added; then one summary record per group (``--by`` keys) with each commit's best
``--metric`` and its ratio to the first commit's. JSON lines out.

    .venv/bin/python experiments/ab_commits.py --commits 0b0b63c HEAD --repeats 2 \\
        --by shape n_blocks --out experiments/results/bench_blocks_commits.jsonl -- \\
        experiments/bench_blocks.py --shape rock --sizes 100 --no-fcp

The benchmark script must run against every commit given (it may test for what a commit has).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time

from jsonl_out import emit

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)


def _git(*args, cwd=ROOT):
    return subprocess.run(["git", *args], cwd=cwd, check=True, capture_output=True, text=True).stdout.strip()


def worktree(commit: str, base: str) -> tuple[str, str]:
    """(full sha, path of a worktree checked out at it), made if missing."""
    sha = _git("rev-parse", commit)
    path = os.path.join(base, sha[:12])
    if not os.path.isdir(path):
        os.makedirs(base, exist_ok=True)
        _git("worktree", "add", "--detach", path, sha)
    return sha, path


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--commits", nargs="+", required=True, help="commits (first: the reference of the ratios)")
    ap.add_argument("--repeats", type=int, default=2)
    ap.add_argument("--metric", default="block_steps_per_s", help="record field to compare (higher is better)")
    ap.add_argument("--by", nargs="*", default=["bench", "n_blocks"], help="record fields that group the summary")
    ap.add_argument("--where", nargs="*", default=[], metavar="KEY=VALUE",
                    help="summarize only records with these fields (e.g. code=rockjax: compare_peers also prints peers)")
    ap.add_argument("--worktrees", default="/tmp/rockjax_ab")
    ap.add_argument("--out", default=None)
    ap.add_argument("--summarize", default=None, metavar="FILE",
                    help="instead of running: the summary records of the per-round records in FILE (an earlier --out)")
    ap.add_argument("script", nargs=argparse.REMAINDER, help="-- SCRIPT [ARGS...], run with the commit's src first on PYTHONPATH")
    a = ap.parse_args(argv)
    script = a.script[1:] if a.script[:1] == ["--"] else a.script
    where = dict(w.split("=", 1) for w in a.where)
    kept = lambda rec: all(str(rec.get(k)) == v for k, v in where.items())  # noqa: E731
    if a.summarize:
        runs: dict = {}
        for line in open(a.summarize):
            rec = json.loads(line)
            if rec.get("bench") != "ab_commits" and a.metric in rec and rec.get("commit_arg") in a.commits and kept(rec):
                runs.setdefault(tuple(rec.get(k) for k in a.by), {}).setdefault(rec["commit_arg"], []).append(
                    float(rec[a.metric]))
        _summary(a, runs, dict(date=time.strftime("%Y-%m-%d"), cmd="experiments/ab_commits.py "
                               + " ".join(sys.argv[1:] if argv is None else argv)))
        return
    if not script:
        ap.error("give the benchmark script after --")
    trees = [worktree(c, a.worktrees) for c in a.commits]
    stamp = dict(date=time.strftime("%Y-%m-%d"), cmd="experiments/ab_commits.py " + " ".join(sys.argv[1:] if argv is None else argv))
    runs: dict = {}
    for rnd in range(a.repeats):
        for (sha, path), name in zip(trees, a.commits):
            env = dict(os.environ, PYTHONPATH=os.pathsep.join([os.path.join(path, "src"), HERE]))
            proc = subprocess.run([sys.executable, *script], cwd=ROOT, env=env, capture_output=True, text=True)
            if proc.returncode:
                raise SystemExit(f"{name} ({sha[:12]}): the script failed:\n{proc.stderr[-3000:]}")
            for line in proc.stdout.splitlines():
                try:
                    rec = json.loads(line)
                except json.JSONDecodeError:
                    continue
                if not isinstance(rec, dict):
                    continue
                emit(dict(rec, commit=sha[:12], commit_arg=name, round=rnd, **stamp,
                          load_avg_1m_at_save=os.getloadavg()[0]), a.out)
                if a.metric in rec and kept(rec):
                    runs.setdefault(tuple(rec.get(k) for k in a.by), {}).setdefault(name, []).append(float(rec[a.metric]))
    _summary(a, runs, stamp)


def _summary(a, runs: dict, stamp: dict) -> None:
    """One record per group: each commit's best and median ``--metric`` over the rounds and their
    ratios to the first commit's (a grouping key named ``bench`` is recorded as ``of_bench``)."""
    import statistics

    for key, by_commit in runs.items():
        best = {n: max(v) for n, v in by_commit.items()}
        median = {n: statistics.median(v) for n, v in by_commit.items()}
        ref, ref_m = best.get(a.commits[0]), median.get(a.commits[0])
        group = {("of_bench" if k == "bench" else k): v for k, v in zip(a.by, key)}
        emit(dict(bench="ab_commits", **group, metric=a.metric,
                  commits={n: _git("rev-parse", "--short=12", n) for n in a.commits}, best=best, median=median,
                  ratio_to_first={n: v / ref for n, v in best.items()} if ref else None,
                  median_ratio_to_first={n: v / ref_m for n, v in median.items()} if ref_m else None,
                  repeats=max(len(v) for v in by_commit.values()), **stamp), a.out)


if __name__ == "__main__":
    main()
