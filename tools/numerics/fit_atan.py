#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Fit the polynomial of num_atan2 (firmware/num/num_fixed.c).

atan(t) ≈ t·(a1 + a3·t² + … + a13·t¹²) on [0, 1], minimising the largest
absolute error (Lawson's iteratively reweighted least squares, which converges
to the minimax fit), and print the coefficients in Q2.30 as the C file holds
them, with the error of the rounded coefficients. Run once, by hand; the C
constants are copied from its output:

    .venv/bin/python tools/numerics/fit_atan.py
"""

import numpy as np

DEGREE = 13
Q = 1 << 30


def fit(degree: int, iters: int = 4000) -> np.ndarray:
    """Minimax coefficients of the odd polynomial, lowest power first."""
    t = 0.5 - 0.5 * np.cos(np.linspace(0.0, np.pi, 40001))  # Chebyshev-spaced
    a = np.stack([t**k for k in range(1, degree + 1, 2)], axis=1)
    y = np.arctan(t)
    w = np.full_like(t, 1.0 / t.size)
    c = np.zeros(a.shape[1])
    for _ in range(iters):
        sw = np.sqrt(w)
        c, *_ = np.linalg.lstsq(a * sw[:, None], y * sw, rcond=None)
        e = np.abs(a @ c - y)
        w = w * e
        w /= w.sum()
    return c


def main() -> None:
    c = fit(DEGREE)
    cq = np.round(c * Q).astype(np.int64)
    t = np.linspace(0.0, 1.0, 200001)
    approx = sum((cq[i] / Q) * t ** (2 * i + 1) for i in range(cq.size))
    err = np.max(np.abs(approx - np.arctan(t)))
    for i, v in enumerate(cq):
        print(f"#define ATAN_A{2 * i + 1} {v if v >= 0 else f'({v})'}")
    print(
        f"/* max |error| with these rounded coefficients: {err:.3g} rad "
        f"= {err * 65536:.3f} LSB of Q16.16 */"
    )


if __name__ == "__main__":
    main()
