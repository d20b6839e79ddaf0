"""The one equation in closed form, for a record at rest until its release under a constant
drive (a tow or a spin by a hung weight): the integrator's fast path (``output_error_fit``).

    (M + M_known + Σ θ_i·w)·v̇ = F + Σ θ·φ(v),  v(0) = 0 at the release (later by Σ δ)

holds in closed form when every force term depends on neither x nor time, and on v only as
v (K_L), |v|·v (K_Q) or a constant that flips with the direction (dry friction, a bias).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from estimation.motion.records import Record
from estimation.motion.terms import Term, TermValues


def _closed_form_term(term: Term) -> bool:
    """A term a constant pull from rest can carry in closed form: an inertia or timing
    term, or a force independent of x and time, of v only as v, |v|·v or sign(v)/a constant."""
    if term.role in ("inertia", "timing"):
        return True
    return term.role == "force" and term.x_power is None and term.v_power in (0, 1, 2)


def applies(records: Sequence[Record], terms: Sequence[Term]) -> bool:
    """Whether every record is a constant pull from rest and every term allows the closed form."""
    return all(map(_closed_form_term, terms)) and all(
        not r.free and r.drive is not None and np.ndim(r.drive) == 0 for r in records
    )


def constant_force_response(
    tau: np.ndarray,
    inertia: np.ndarray,
    k_l: np.ndarray,
    k_q: np.ndarray,
    force: np.ndarray,
    at: np.ndarray | None = None,
    counts: Sequence[int] | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Displacement and velocity from rest under a constant force ≥ 0 (closed form).

    Solves M v̇ = F − K_L v − K_Q v², v(0) = 0:  v = v∞(1 − E)/(1 + aE), E = e^{−λt},
    λ = √(K_L² + 4K_Q F)/M, v∞ = 2F/(K_L + √·), a = 4K_Q F/(K_L + √·)²;
    x = v∞[t + (1 + a)/λ · (ln(1 + aE) − ln(1 + a))/a]. Parameter arrays broadcast as (S, 1);
    with ``at`` (the parameters' column of each of ``tau``'s columns: records (S, R) of
    samples (S, n)) what depends on the parameters alone is computed once per record;
    ``counts``: instead of ``at`` when each record's samples are contiguous, how many each
    has (the same numbers, spread by ``np.repeat``: 5× cheaper than indexing by ``at``).
    """
    disc = np.sqrt(k_l**2 + 4.0 * k_q * force)
    denom = np.maximum(k_l + disc, 1e-300)
    v_inf = 2.0 * force / denom
    a = 4.0 * k_q * force / denom**2
    lam = np.maximum(disc, 1e-300) / inertia
    small = a < 1e-7
    a_safe = np.where(small, 1.0, a)
    log_a = np.log1p(a_safe)
    # ``gain / lam`` and ``−lam`` per record, then spread over its samples: an elementwise
    # operation gives the same number before or after the gather, once per record
    spread = gain_over_lam = (1.0 + a) / lam
    rate = -lam
    mixed = bool(np.any(small)) and not bool(np.all(small))
    if at is not None or counts is not None:

        def per_sample(p: np.ndarray) -> np.ndarray:
            return p[:, at] if counts is None else np.repeat(p, counts, axis=1)

        v_inf, a, a_safe, log_a, gain_over_lam, rate = map(
            per_sample, (v_inf, a, a_safe, log_a, spread, rate)
        )
        small = per_sample(small) if mixed else small
    e = np.exp(rate * tau)
    # each sample's branch only (a branch where no sample needs it is not formed): the
    # same numbers as np.where over both
    if mixed:
        ratio = np.where(
            small,
            (e - 1.0) - a * (e * e - 1.0) / 2.0,
            (np.log1p(a_safe * e) - log_a) / a_safe,
        )
    elif np.any(small):
        ratio = (e - 1.0) - a * (e * e - 1.0) / 2.0
    else:
        ratio = (np.log1p(a_safe * e) - log_a) / a_safe
    x = v_inf * (tau + gain_over_lam * ratio)
    v = v_inf * (1.0 - e) / (1.0 + a * e)
    return x, v


def pull_response(
    records: Sequence[Record],
    total_inertia: np.ndarray,
    coefficients: Sequence[TermValues],
    shift: np.ndarray,
) -> list[tuple[np.ndarray, np.ndarray]]:
    """x from the rest position and ẋ at each record's samples, per parameter set (S, n).

    ``total_inertia`` (S, R) (``equation.total_inertia``); ``coefficients`` the force terms'
    values (S, 1) or (S, R); ``shift`` (S,) the timing terms' delay (s). Per record, K_L and
    K_Q are Σ θ·(−φ(0, 1)) over the v and |v|·v terms, and the constant forces moving forward
    and backward Σ θ·φ(0, ±1) over the others: the body moves forward when F + the forward
    one > 0, backward when F + the backward one < 0, and dry friction holds it otherwise.
    Every record's samples are solved in one call (each sample's arithmetic is its own)."""
    zero, one = np.zeros(1), np.ones(1)
    n, nr = total_inertia.shape[0], len(records)
    k_l, k_q = np.zeros((n, nr)), np.zeros((n, nr))
    forward, backward = np.zeros((n, nr)), np.zeros((n, nr))
    for c in coefficients:
        if c.term.role != "force":
            continue
        value = c.value[:, np.minimum(np.arange(nr), c.value.shape[1] - 1)]  # (S, 1) or (S, R)
        if c.term.v_power == 1:
            k_l = k_l - value * c.term.phi(zero, one)
        elif c.term.v_power == 2:
            k_q = k_q - value * c.term.phi(zero, one)
        else:
            forward = forward + value * c.term.phi(zero, one)
            backward = backward + value * c.term.phi(zero, -one)
    force = np.array([float(np.asarray(r.drive)) for r in records])
    ahead, behind = force + forward, force + backward
    s = np.where(ahead > 0, 1.0, np.where(behind < 0, -1.0, 0.0))
    f_eff = np.where(ahead > 0, ahead, np.where(behind < 0, -behind, 0.0))
    sizes = [np.size(r.t) for r in records]
    at = np.repeat(np.arange(nr), sizes)  # each sample's record
    released = np.array([r.released_at for r in records], dtype=float)
    t = np.concatenate([np.asarray(r.t, dtype=float) for r in records])
    tau = np.maximum(t[None, :] - released[at][None, :] - shift[:, None], 0.0)
    x, v = constant_force_response(tau, total_inertia, k_l, k_q, f_eff, counts=sizes)
    sign = np.repeat(s, sizes, axis=1)
    x, v = sign * x, sign * v
    ends = np.cumsum(sizes)[:-1]
    return list(zip(np.split(x, ends, axis=1), np.split(v, ends, axis=1), strict=True))
