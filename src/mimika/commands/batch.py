"""``mimika batch``: render a stimulus set or a training set from a YAML spec on Dask."""

from __future__ import annotations

import argparse
import sys

from mimika.commands._util import limit_options, progress_bar


def cmd_batch(args: argparse.Namespace) -> int:
    from mimika.batch import load_spec, make_plan
    from mimika.batch.run import run_batch
    from mimika.errors import ParameterError
    from mimika.limits import check_count

    if args.workers is not None and args.workers < 1:
        raise ParameterError(f"--workers {args.workers} must be ≥ 1")
    if args.workers is not None:
        check_count("max_workers", args.workers, "--workers")
    if args.workers is not None and args.scheduler:
        raise ParameterError("--workers sizes the local cluster; do not combine it with "
                             "--scheduler")
    if args.chunk is not None and args.chunk < 1:
        raise ParameterError(f"--chunk {args.chunk} must be ≥ 1")
    spec = load_spec(args.spec)
    plan = make_plan(spec)
    if args.dry_run:
        r = run_batch(plan, args.output, dry_run=True)
        print(f"{args.spec}: {r.total} items ({r.skipped} finished, {r.pending} to render) "
              f"→ {args.output}")
        print(f"  heads {', '.join(spec.heads)}; views {', '.join(spec.views)}; "
              f"size {spec.size[0]}x{spec.size[1]}; {len(plan.au_columns)} AU label columns"
              + (f"; clips as {plan.clip_format}" if plan.clip_format else ""))
        for it in r.todo[: args.show]:
            aus = " ".join(f"{c}={v:g}" for c, v in it.aus.items() if v) or "neutral"
            rules = f"  [{' '.join(it.rules)}]" if it.rules else ""
            print(f"  {it.file}  {aus}{rules}")
        if len(r.todo) > args.show:
            print(f"  … {len(r.todo) - args.show} more")
        return 0
    r = run_batch(plan, args.output, workers=args.workers, scheduler=args.scheduler,
                  chunk=args.chunk, progress=progress_bar(args.quiet, "rendering"))
    if r.failed:
        print(f"mimika: {r.failed} of {r.total} items failed (retried on the next run; see "
              f"{r.out / 'manifest.json'}): {r.errors[0]}", file=sys.stderr)
    if not args.quiet:
        plural = "s" if r.workers != 1 else ""
        rate = (f" ({r.images_per_s:.2f} images/s on {r.workers} worker{plural})"
                if r.rendered else "")
        print(f"{r.out}: {r.rendered} rendered, {r.skipped} already done, {r.failed} failed "
              f"of {r.total} in {r.wall_s:.1f} s{rate}; labels in {r.out / 'labels.csv'}")
    return 1 if r.failed else 0


def register(sub) -> None:
    q = sub.add_parser("batch", help="render a stimulus or training set from a YAML spec (Dask)",
                       description="Render every item of a batch spec (see docs/batch.md) into "
                                   "OUT: images/, clips/, labels.csv and manifest.json. Reruns "
                                   "skip finished items.")
    q.add_argument("spec", help="the batch spec (YAML)")
    q.add_argument("-o", "--output", required=True, metavar="OUT", help="output folder")
    q.add_argument("--workers", type=int, metavar="N",
                   help="worker processes of the local Dask cluster (default: CPU count, ≤ 8)")
    q.add_argument("--scheduler", metavar="tcp://HOST:PORT",
                   help="use an existing Dask scheduler instead of a local cluster (workers "
                        "must have mimika installed)")
    q.add_argument("--chunk", type=int, metavar="K",
                   help="items per Dask task (default: about four tasks per worker)")
    q.add_argument("--dry-run", action="store_true",
                   help="validate the spec and list what would be rendered")
    q.add_argument("--show", type=int, default=10, metavar="K",
                   help="items listed by --dry-run (default 10)")
    q.add_argument("-q", "--quiet", action="store_true")
    limit_options(q, "max_items")
    q.set_defaults(func=cmd_batch)
