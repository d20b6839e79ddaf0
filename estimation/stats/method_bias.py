"""A seed method's coefficients against the output-error fit of the same records.

A seed method (a tow's ``ls-raw``/``ls-curvefit``/``ls-steady``, a pendulum's ``damped-fit``,
``log-decrement``, ``equation-error``) models the record more simply than the one engine's
integrated fit: differenced derivatives of noisy positions, a first-order curve's steady
speed taken as the terminal speed, a linear decay where the drag is quadratic or the pivot
rubs. Its U covers the noise and the declared inputs, not that model: where it sits further
than ``DISAGREES_SIGMAS``·√(σ_seed² + σ_oe²) from the output-error fit, the result says so.
Both σ count the residual's serial correlation; the two estimates share the records, so the
σ of their difference is at most that root sum and the rule errs toward silence.

Measured on synthetic tows (solve_ivp, 10, 143 and 1000 kg, white and AR(1) ρ 0.9 position
noise, 10 seeds each): ls-raw sat 5.6–8.8 σ (median) from the output-error fit and ls-steady
21–80 σ, named in every seed; ls-curvefit 0.6–0.7 σ, named in none: its σ is wide enough
to hide its bias, which the misfit of the positions its coefficients predict shows instead
(``axis.unexplained.Unexplained.seed_warning``). A pendulum's seed headline (its rows pooled
over runs), and each of its rows against the output-error row of its run, are compared with
the output-error fit after the search, the result a user is told to sign: a linear decay's β
takes up the quadratic drag or pivot friction that fit found.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

from estimation.report_numbers import Coefficient

#: z of the difference from the output-error fit beyond which a seed method is called biased
#: (two-sided 95 % for a normal difference; see the module doc for why it errs to silence).
DISAGREES_SIGMAS = 2.0


def z_scores(
    seed: Mapping[str, Coefficient], reference: Mapping[str, Coefficient]
) -> dict[str, float]:
    """|seed − reference| / √(σ_seed² + σ_ref²) of every coefficient both name with a σ."""
    out = {}
    for name, s in seed.items():
        r = reference.get(name)
        if r is None or s.std is None or r.std is None:
            continue
        z = abs(s.value - r.value) / math.hypot(s.std, r.std)
        if math.isfinite(z):
            out[name] = float(z)
    return out


def apart(seed: Mapping[str, Coefficient], reference: Mapping[str, Coefficient]) -> list[str]:
    """ "name value against value unit (z σ)" for each coefficient of ``seed`` further than
    ``DISAGREES_SIGMAS`` from ``reference``."""
    return [
        f"{name} {seed[name].value:.4g} against {reference[name].value:.4g} "
        f"{seed[name].unit} ({z:.1f} σ)"
        for name, z in z_scores(seed, reference).items()
        if z > DISAGREES_SIGMAS
    ]


def method_bias(
    method: str, seed: Mapping[str, Coefficient], reference: Mapping[str, Coefficient]
) -> list[str]:
    """One warning naming every coefficient of ``seed`` (the ``method``'s) further than
    ``DISAGREES_SIGMAS`` σ of the difference from the same name in ``reference`` (the
    output-error fit of the same records); empty when none is, or no σ is known."""
    far = apart(seed, reference)
    if not far:
        return []
    return [
        f"{method} is biased on these runs: {'; '.join(far)} from the output-error fit of "
        "the same runs. The bias is the method's own model of the record and its U does not "
        "cover it: sign the output-error result"
    ]
