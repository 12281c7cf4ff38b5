"""Recording of the box golden files (see :mod:`tests.golden.record`; not a test module)."""
from __future__ import annotations

import numpy as np

from impactnet.models.box.exact import box_box
from tests.golden import rule, store
from tests.golden.box_margins import box_margins, disagreements
from tests.golden.box_sets import BUILDERS
from tests.golden.sensitivity import box_sensitivity
from tests.models.helpers import KEYS


class ModelMismatch(AssertionError):
    """The margins' own decisions differ from the solver's on a row that is not borderline:
    the margin code no longer models the solver's rule, so its margins cannot be trusted."""


def check_model(name: str, margins, contacts) -> None:
    """Raise :class:`ModelMismatch` where the redone decisions differ from the solver's."""
    wrong = disagreements(margins, contacts.colliding, contacts.axis, contacts.contact_type_code)
    bad = {kind: rows[:10].tolist() for kind, rows in wrong.items() if len(rows)}
    if bad:
        raise ModelMismatch(f"box set {name!r}: decisions differ from the solver's on clear "
                            f"rows {bad}")


def record_box_set(name: str, note: str, folder=store.GOLDEN_DIR) -> dict:
    """Build, solve and store one box set; returns its summary (rows, causes, file size)."""
    poses = BUILDERS[name]()
    inputs = [np.ascontiguousarray(poses[k], np.float64) for k in KEYS]
    contacts = box_box(*inputs)
    margins = box_margins(*inputs)
    check_model(name, margins, contacts)
    arrays = dict(zip(KEYS, inputs))
    arrays.update(family=poses["family"], families=poses["families"],
                  margin_names=np.array(rule.MARGIN_NAMES), note=np.array(note))
    arrays.update(store.pack_contacts(contacts))
    arrays.update(store.pack_rule(margins))
    sensitivity, flips = box_sensitivity(dict(zip(KEYS, inputs)),
                                         store.unpack_contacts(store.pack_contacts(contacts)))
    arrays["sensitivity"] = sensitivity.astype(np.float32)
    path = store.save(f"box_{name}", arrays, folder)
    clear = margins.causes == 0
    return {"rows": len(inputs[0]), "causes": rule.cause_counts(margins.causes),
            "ill_conditioned": int((clear & (sensitivity > rule.MATCH_TOL_REL)).sum()),
            "probe_flips_on_clear": int((clear & flips).sum()), "bytes": path.stat().st_size}
