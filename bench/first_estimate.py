"""The first estimate a browser asks of a freshly started service, and the next one.

A user starts ``rig serve``, records (or imports) a run and presses Estimate: the job's
latency is what they wait. The fit runs in the process's analysis worker
(``api.core.analysis_executor``); this times, on the published KVLCC2 roll decay 21337
(``rig import --kind decay --dof roll``, as bench/estimate_process.py) imported into a
temporary SQLite database:

* ``at_first_job``: the service as it ships, when no test came first (the run here is
  imported): the analysis worker and the server it forks from (``api.core.worker_processes``)
  start with the first analysis, which waits for the server's imports (an idle service holds
  neither, and a test started on it starts the server: ``bench/serve_idle.py``);
* ``prestarted``: the worker and its server started with the service (as fabf1ff did) and
  given ``--lead`` seconds (the length of a short test) before the estimate is asked for;

each with the wall time from POST ``/api/jobs/estimation`` to ``completed`` for the first job
and for a second one on the same service, ``--lead`` seconds after the service started. Each
case runs in a fresh process of this script (a process has one analysis worker), the cases
alternated ``--repeat`` times. Prints one JSON document: each run and the medians.
Run: .venv/bin/python bench/first_estimate.py [--lead 5] [--repeat 3]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from bench.estimate_process import KVLCC2, imported  # noqa: E402
from bench.service import serve_in_thread, wait_job  # noqa: E402

TOKEN = "bench-token"
CASES = ("at_first_job", "prestarted")


def one_case(db_url: str, run_id: str, prestart: bool, lead_s: float) -> dict[str, float]:
    """Start the service on ``db_url``, wait ``lead_s``, time two estimation jobs (s)."""
    import httpx

    from api.core.analysis_executor import shared_process_executor

    service, _app, server, thread, base = serve_in_thread(db_url, TOKEN, realtime=False)
    if prestart:
        shared_process_executor().start()
    out: dict[str, float] = {}
    try:
        time.sleep(lead_s)  # the user records or imports meanwhile
        with httpx.Client(base_url=base, headers={"Authorization": f"Bearer {TOKEN}"}) as http:
            for label in ("first_s", "second_s"):
                t0 = time.perf_counter()
                body = {"run_ids": [run_id], "search_effects": True}
                job = http.post("/api/jobs/estimation", json=body).json()
                done = wait_job(http, job["id"], ("completed", "failed"), timeout_s=300)
                if done["state"] != "completed":
                    raise SystemExit(f"estimation failed: {done.get('error')}")
                out[label] = round(time.perf_counter() - t0, 2)
    finally:
        server.should_exit = True
        thread.join(30)
        service.stop()
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--lead", type=float, default=5.0, help="Seconds before the estimate.")
    parser.add_argument("--repeat", type=int, default=3, help="Rounds of both cases.")
    parser.add_argument("--case", choices=CASES)
    parser.add_argument("--db", help=argparse.SUPPRESS)
    parser.add_argument("--run", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.case:  # a child: one case in this fresh process
        result = one_case(args.db, args.run, args.case == "prestarted", args.lead)
        print(json.dumps(result))
        return
    with tempfile.TemporaryDirectory(prefix="bench-first-estimate-") as tmp:
        db_url = f"sqlite:///{Path(tmp) / 'rig.db'}"
        env = os.environ | {"RIG_DATABASE_URL": db_url}
        run_id = imported(KVLCC2, env, tmp)
        runs: dict[str, list[dict[str, float]]] = {case: [] for case in CASES}
        for _ in range(args.repeat):
            for case in CASES:
                argv = [sys.executable, __file__, "--case", case, "--lead", str(args.lead)]
                proc = subprocess.run(
                    [*argv, "--db", db_url, "--run", run_id],
                    env=env,
                    capture_output=True,
                    text=True,
                    check=False,
                )
                if proc.returncode != 0:
                    raise SystemExit(f"{case} failed: {proc.stderr.strip()[-2000:]}")
                runs[case].append(json.loads(proc.stdout.strip().splitlines()[-1]))
    medians = {
        case: {key: statistics.median(r[key] for r in found) for key in found[0]}
        for case, found in runs.items()
    }
    doc = {
        "record": "kvlcc2 21337 (published roll decay)",
        "lead_s": args.lead,
        "median": medians,
        "runs": runs,
        "first_ratio_at_first_job_to_prestarted": round(
            medians["at_first_job"]["first_s"] / medians["prestarted"]["first_s"], 3
        ),
    }
    print(json.dumps(doc, indent=2))


if __name__ == "__main__":
    main()
