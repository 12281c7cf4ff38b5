"""Record today's answers as golden files: ``python -m tests.golden.record --reason "..."``.

    python -m tests.golden.record --reason "first recording, before the numba switch"
    python -m tests.golden.record --reason "..." --sets box_stacking compound_cell_guide

Writes ``tests/data/golden/<set>.npz`` for the box sets (:mod:`tests.golden.box_sets`:
``box_scene``, ``box_stacking``, ``box_figure2``, ``box_extremes``) and the compound sets
(:mod:`tests.golden.compound_sets`: ``compound_castings``, ``compound_apertures``,
``compound_twistlocks_8`` .. ``_256``, ``compound_cell_guide``), each with the inputs, every
output field, the margins of the comparison rule (:mod:`tests.golden.rule`) and each row's
rounding sensitivity (:mod:`tests.golden.sensitivity`), and ``summary.json``: rows, borderline
rows by cause, ill-conditioned clear rows and file sizes per set, with the reason. About a
minute and a half on one core (the twistlocks' first-contact searches take most of it).

When to re-record: only when an answer is meant to change (a documented change of the rule,
a new field), never to make ``tests/models/box/test_golden.py`` or
``tests/models/compound/test_golden.py`` pass after an unintended change; ``--reason`` is
required and is stored in every file and in the summary, and the commit that changes the
golden files says why. The recorder refuses to write a set whose margin code disagrees with
the solver on a clear row (:class:`tests.golden.record_box.ModelMismatch`).

The recorder reads the training benches' pose generators; the tests read only the files.
"""
from __future__ import annotations

import argparse
import json
import time

from tests.golden import rule, store
from tests.golden.box_sets import BUILDERS as BOX_BUILDERS
from tests.golden.compound_sets import SETS as COMPOUND_SETS
from tests.golden.record_box import record_box_set
from tests.golden.record_compound import record_compound_set

SET_NAMES = tuple(f"box_{n}" for n in BOX_BUILDERS) + tuple(f"compound_{n}"
                                                             for n in COMPOUND_SETS)
SUMMARY = "summary.json"


def record(names, reason: str, folder=store.GOLDEN_DIR) -> dict:
    """Record the sets ``names`` (see :data:`SET_NAMES`); returns and writes the summary (sets
    not recorded now keep their previous entry)."""
    rule.check_solver_constants()
    path = folder / SUMMARY
    summary = json.loads(path.read_text()) if path.exists() else {"sets": {}}
    for name in names:
        start = time.perf_counter()
        kind, _, set_name = name.partition("_")
        entry = (record_box_set(set_name, reason, folder) if kind == "box"
                 else record_compound_set(set_name, reason, folder))
        entry["reason"] = reason
        summary["sets"][name] = entry
        print(f"{name}: {entry['rows']} rows, {entry['bytes'] / 1e3:.0f} kB, borderline "
              f"{ {k: v for k, v in entry['causes'].items() if v and k != 'clear'} }, "
              f"ill-conditioned clear rows {entry['ill_conditioned']}, probe flips on clear "
              f"rows {entry['probe_flips_on_clear']} ({time.perf_counter() - start:.1f} s)",
              flush=True)
    summary["total_bytes"] = sum(e["bytes"] for e in summary["sets"].values())
    folder.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(summary, indent=1, sort_keys=True) + "\n")
    return summary


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--reason", required=True,
                        help="why the answers are (re-)recorded; stored with them")
    parser.add_argument("--sets", nargs="+", choices=SET_NAMES, default=list(SET_NAMES))
    args = parser.parse_args(argv)
    record(args.sets, args.reason)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
