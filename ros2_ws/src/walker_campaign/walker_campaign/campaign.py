"""``campaign.py SPEC``: run a campaign of walks on Ray, resume it, re-run one run, report.

::

    python3 scripts/campaign.py SPEC                   # run (or resume) on this machine, report
    python3 scripts/campaign.py SPEC --workers 2       # at most two walks at once
    python3 scripts/campaign.py SPEC --address HOST:PORT   # on a running Ray cluster
    python3 scripts/campaign.py SPEC --check           # check the spec and every run, run none
    python3 scripts/campaign.py SPEC --run-index 17    # run 17 again alone, compare its row
    python3 scripts/campaign.py SPEC --run-index 17 --bag   # ... and write its bag and report
    python3 scripts/campaign.py SPEC --report-only     # the report from the results so far
    python3 scripts/campaign.py SPEC --truss-survey FILE   # every walk starts from a survey

Results go to ``<out>/results.jsonl`` (``--out``, default ``runs/campaigns/<name>``), the
report to ``<out>/report/``. Exit codes: 0 complete, 1 a re-run differs from its row, 2 a bad
spec or option, 3 runs left to do (lost workers: run the same command again to resume),
130 interrupted (Ctrl-C or SIGTERM; resumable too).
"""

from __future__ import annotations

import argparse
import json
import signal
import sys
import time
from pathlib import Path

from walker_campaign.core.errors import ResultsError, SpecError
from walker_campaign.core.plan import check_every_run, plan_run
from walker_campaign.core.progress import duration_text, progress_text
from walker_campaign.core.report import make_campaign_report
from walker_campaign.core.results import ResultsWriter, read_results
from walker_campaign.core.rows import RUN, deterministic_part
from walker_campaign.core.spec import CampaignSpec, find_spec, load_spec, with_truss_survey
from walker_campaign.execution import RunTask, execute_run
from walker_report.progress import ProgressLine

__all__ = ['main', 'parse_arguments', 'DEFAULT_WALK']

#: The walk function campaigns use unless ``--graph`` is given: the fast path.
DEFAULT_WALK = 'headless'


def parse_arguments(argv: list[str] | None = None) -> argparse.Namespace:
    """Command-line options of ``campaign.py``."""
    parser = argparse.ArgumentParser(
        prog='campaign.py', description='Run a Monte Carlo or sweep campaign of walks on Ray '
        '(locally, or on a cluster with --address), resume it, and write its report.')
    parser.add_argument('spec', help='the campaign spec (YAML; docs/campaigns.md), or the name '
                                     'of a shipped one (default_walk, ka_filter_sweep, '
                                     'truss_as_built, truss_as_built_camera, truss_twice)')
    parser.add_argument('--out', default=None,
                        help='output directory (default: runs/campaigns/<name>)')
    parser.add_argument('--address', default=None,
                        help="a running Ray cluster's address (host:port); default: a Ray of "
                             "this process's own on this machine")
    parser.add_argument('--workers', type=int, default=None,
                        help='local Ray: walks at once (default: one per CPU)')
    parser.add_argument('--graph', action='store_true',
                        help='walk on the full sim-time ROS graph, in a ROS domain of its own '
                             'on the worker, instead of the headless runner')
    parser.add_argument('--walk', default=None, metavar='MODULE:FUNCTION',
                        help='a walk function of your own, importable where the walks run '
                             '(walker_campaign.walks explains the interface)')
    parser.add_argument('--truss-survey', default=None, metavar='FILE',
                        help="every walk starts from this truss survey (a walk's "
                             "truss_survey.yaml), in place of the spec's truss_survey")
    parser.add_argument('--check', action='store_true',
                        help="check the spec and every run's parameters; run nothing")
    parser.add_argument('--run-index', type=int, default=None, metavar='K',
                        help='run K again alone, here, and compare its rows with the results')
    parser.add_argument('--bag', action='store_true',
                        help='with --run-index: record the walk and write its walk report')
    parser.add_argument('--report-only', action='store_true',
                        help='write the report from the results so far; run nothing')
    parser.add_argument('--no-report', dest='report', action='store_false',
                        help='do not write the report at the end')
    parser.add_argument('--max-retries', type=int, default=3,
                        help='times Ray runs a walk again after its worker died (default 3)')
    parser.add_argument('--quiet', action='store_true', help='no progress line')
    args = parser.parse_args(argv)
    if args.workers is not None and (args.workers < 1 or args.address):
        parser.error('--workers is a positive number of local walks at once (not with '
                     '--address: a cluster has the CPUs its nodes were started with)')
    if args.bag and args.run_index is None:
        parser.error('--bag records one run: give --run-index K')
    if args.walk and args.graph:
        parser.error('--graph and --walk each choose the walk: give one')
    if args.max_retries < 0:
        parser.error('--max-retries must be 0 or more')
    return args


def _say(text: str) -> None:
    print(f'[campaign] {text}', flush=True)


def _describe(spec: CampaignSpec) -> str:
    grid = (f'{spec.point_count} grid points x {spec.runs} runs' if spec.sweeps
            else f'{spec.runs} runs')
    walks = f' ({spec.walks} walks each on the same truss)' if spec.walks > 1 else ''
    survey = (f', starting from the truss survey {spec.truss_survey_file}'
              if spec.truss_survey is not None else '')
    unit = 'runs' if spec.walks > 1 else 'walks'
    return (f'{spec.name}: {grid}{walks} = {spec.total_runs} {unit} to {spec.target}, '
            f'{len(spec.dispersions)} dispersion{"s" if len(spec.dispersions) != 1 else ""}, '
            f'seed {spec.seed}{survey}')


def _task(spec: CampaignSpec, index: int, walk: str, record_dir: str | None = None) -> RunTask:
    return RunTask(spec.name, plan_run(spec, index), spec.target, spec.walk_timeout, walk,
                   record_dir, spec.truss_survey, spec.walks)


def _run_campaign(spec: CampaignSpec, args, results_path: Path, walk: str) -> int:
    from walker_campaign.ray_runner import RayCampaign

    check_every_run(spec)
    with ResultsWriter(results_path, spec) as writer:
        pending = [i for i in range(spec.total_runs) if i not in writer.finished]
        done = spec.total_runs - len(pending)
        _say(f'{_describe(spec)}; {done} done already, {len(pending)} to run; results in '
             f'{results_path}')
        if not pending:
            return 0
        finished = read_results(results_path).run_rows if done else []
        counts = {'done': done, 'reached': sum(r['reached'] for r in finished),
                  'walks': sum(r['outcome'] != 'error' for r in finished), 'now': 0}
        progress = ProgressLine(args.quiet, prefix='[campaign]')
        started = time.monotonic()

        def on_rows(rows: list[dict]) -> None:
            writer.append(rows)
            run = rows[-1]
            counts['done'] += 1
            counts['now'] += 1
            counts['reached'] += bool(run['reached'])
            counts['walks'] += run['outcome'] != 'error'
            progress(progress_text(counts['done'], spec.total_runs, counts['reached'],
                                   counts['walks'], counts['now'], time.monotonic() - started),
                     counts['done'], spec.total_runs)

        try:
            with RayCampaign(args.address, args.workers, args.max_retries) as ray:
                signal.signal(signal.SIGTERM, _interrupt)  # again: Ray's start replaced it
                _say(f'Ray: {ray.cpus} CPUs' + (f' at {args.address}' if args.address
                                                 else ' on this machine (127.0.0.1)'))
                lost = ray.run([_task(spec, i, walk) for i in pending], spec.document, on_rows)
        finally:
            progress.close()
        _say(f'{counts["now"]} walks in {duration_text(time.monotonic() - started)}')
        for index, reason in sorted(lost.items()):
            _say(f'run {index} lost (its workers died): {reason}')
        if lost:
            _say(f'{len(lost)} runs left to do: run the same command again to resume')
            return 3
    return 0


def _rerun(spec: CampaignSpec, args, out: Path, results_path: Path, walk: str) -> int:
    index = args.run_index
    plan_run(spec, index)  # a SpecError for an index outside the campaign
    record_dir = out / 'runs' / f'{index:05d}' if args.bag else None
    _say(f'run {index} of {_describe(spec)}, here' + (f', recorded in {record_dir}'
                                                       if record_dir else ''))
    rows = execute_run(_task(spec, index, walk, str(record_dir) if record_dir else None),
                       spec.document)
    run = rows[-1]
    _say(f'run {index}: {run["outcome"]}' + (f' ({run["cause"]})' if run['cause'] else '')
         + f', {run["steps"]} steps')
    print(json.dumps(deterministic_part(run), indent=1), flush=True)
    if record_dir is not None:
        _walk_report(record_dir)
    if not results_path.is_file():
        return 0
    results = read_results(results_path)
    if index not in results.runs:
        _say(f'run {index} is not in {results_path} yet: nothing to compare')
        return 0
    stored = [deterministic_part(r) for r in [*results.steps.get(index, []),
                                              results.runs[index]]]
    now = [deterministic_part(r) for r in rows]
    if stored == now:
        _say(f'run {index}: every row identical to {results_path} ({len(now)} rows)')
        return 0
    for old, new in zip(stored, now, strict=False):
        for key in sorted(set(old) | set(new)):
            if old.get(key) != new.get(key):
                kind = 'run' if old.get('kind') == RUN else f'step {old.get("step")}'
                _say(f'run {index}, {kind} row: {key} was {old.get(key)!r}, now '
                     f'{new.get(key)!r}')
    if len(stored) != len(now):
        _say(f'run {index}: {len(stored)} rows in the results, {len(now)} now')
    return 1


def _walk_report(record_dir: Path) -> None:
    from walker_report.core.report import make_report

    bags = sorted(p.parent for p in record_dir.rglob('metadata.yaml'))
    if not bags:
        _say(f'no bag was recorded in {record_dir}')
        return
    result = make_report(bags[0], record_dir / 'report', record_dir / 'model.yaml',
                         progress=ProgressLine(prefix='[campaign] walk report:'))
    _say(f'walk report: {result.markdown}')


def _interrupt(signum, frame) -> None:
    raise KeyboardInterrupt


def main(argv: list[str] | None = None) -> int:
    """Run the command line; return the exit code."""
    args = parse_arguments(sys.argv[1:] if argv is None else argv)
    signal.signal(signal.SIGTERM, _interrupt)  # a scheduler's stop: as Ctrl-C, resumable
    try:
        spec = load_spec(find_spec(args.spec))
        if args.truss_survey is not None:
            spec = with_truss_survey(spec, args.truss_survey)
        out = Path(args.out or Path('runs') / 'campaigns' / spec.name).resolve()
        results_path = out / 'results.jsonl'
        walk = args.walk or ('graph' if args.graph else DEFAULT_WALK)
        if args.check:
            check_every_run(spec)
            _say(f'{_describe(spec)}: every run checked')
            return 0
        if args.run_index is not None:
            return _rerun(spec, args, out, results_path, walk)
        code = 0 if args.report_only else _run_campaign(spec, args, results_path, walk)
    except (SpecError, ResultsError) as error:
        _say(f'error: {error}')
        return 2
    except KeyboardInterrupt:
        _say('interrupted: run the same command again to resume')
        return 130
    if args.report:
        tolerance = spec.nominal.get('gripper.insertion_position_tolerance')
        command = f'python3 scripts/campaign.py {args.spec}' + (
            f' --truss-survey {args.truss_survey}' if args.truss_survey else '')
        report = make_campaign_report(results_path, out / 'report', tolerance, command)
        _say(f'report: {report.markdown}')
    return code


if __name__ == '__main__':
    sys.exit(main())
