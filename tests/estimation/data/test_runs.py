"""Input validation: clear errors naming the field, the value and what is allowed."""

import dataclasses

import numpy as np
import pytest

from estimation import RunData, estimate


def _run(**kw):
    t = np.arange(0.0, 5.0, 0.1)
    base = dict(
        run_id="a",
        axis="surge",
        t=t,
        position=0.01 * np.clip(t - 1, 0, None) ** 2,
        drive=4.9,
        t_release=1.0,
    )
    base.update(kw)
    return RunData(**base)


def test_unknown_method_names_allowed_values():
    with pytest.raises(ValueError, match=r"method: got 'magic'.*output-error.*ls-raw"):
        estimate([_run()], method="magic")


def test_mixed_axes_rejected():
    with pytest.raises(ValueError, match=r"axis: got mixed axes \['surge', 'yaw'\]"):
        estimate([_run(), _run(run_id="b", axis="yaw")])


def test_nan_position_rejected():
    x = _run().position.copy()
    x[7] = np.nan
    with pytest.raises(ValueError, match=r"run 'a': position: got 'NaN/inf'"):
        estimate([_run(position=x)])


def test_too_few_samples_after_release():
    with pytest.raises(ValueError, match=r"run 'a': t: got '2 samples after release'.*>= 5"):
        estimate([_run(t_end=1.25)])


def test_unknown_axis_and_bad_mass():
    with pytest.raises(ValueError, match=r"axis: got 'heave'"):
        estimate([_run(axis="heave")])
    with pytest.raises(ValueError, match=r"hung_mass_kg: got -1"):
        estimate([_run(hung_mass_kg=-1.0)])


def test_duplicate_ids_and_shape_mismatch():
    with pytest.raises(ValueError, match="run_id: got duplicates"):
        estimate([_run(), _run()])
    run = _run()
    with pytest.raises(ValueError, match="position: got 'shape"):
        estimate([dataclasses.replace(run, position=run.position[:-1])])
