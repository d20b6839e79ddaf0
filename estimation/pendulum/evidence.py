"""The pendulum's search steps in its documented keys (docs/pendulum.md, *evidence*).

Each step carries the Ljung–Box Q of its round's model and of its trial
(``estimation.motion.term_selection.Step``): evidence beside ΔBIC and the materiality figures that a
reader can compare with a tow's, never the reason a term was kept or rejected (whiteness is
a verdict on the final model: with structure left in the residual its normalised
autocorrelation stays near 1 whatever share a true term removes). Q after is null for a
candidate never fitted (screened out by its linearised step, not identified, out of bounds).
"""

from __future__ import annotations

from typing import Any

from estimation.motion.term_selection import Step


def step_json(s: Step) -> dict[str, Any]:
    """One search step in the documented keys."""
    doc = s.to_json()
    return {
        "round": doc["round"],
        "effect": doc["term"],
        "delta_bic": doc["delta_bic"],
        "ljung_box_q_before": doc["ljung_box_q_before"],
        "ljung_box_q_after": doc["ljung_box_q_after"],
        # the leave-one-run-out RMSE of the model without and with the term, under the
        # key a tow's step has it (null: fewer than 3 runs, or the rule not reached)
        "cv_rmse_before": doc["leave_one_record_out_rmse_before"],
        "cv_rmse_after": doc["leave_one_record_out_rmse_after"],
        "explained_rms": doc["explained_rms"],
        "noise": doc["noise"],
        "accepted": doc["accepted"],
        "added": doc["added"],
        "reason": doc["reason"],
    }
