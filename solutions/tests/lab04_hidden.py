"""Hidden tests for lab 04 (instructor material: never copied into labs/)."""

import control
import numpy as np

from pendkit.control.model import FurutaModel, discretise
from pendkit.grading import expect, task
from pendkit.rig import RigParams

gain = task("04.lqr_gain", function="lqr_gain", title="A discrete LQR gain")
poles = task("04.closed_loop_poles", function="closed_loop_poles", title="Closed-loop poles")


@gain.test(points=1, hidden=True, hint="The gain must stabilise the model for any sensible weights.")
def stabilises_other_weights(fn, rng):
    system = discretise(FurutaModel.from_rig(RigParams.preset("turnigy-tgy-wp23")).linearise("upright"), 0.06)
    a, b = np.asarray(system.A), np.asarray(system.B)
    for q, r in [([1, 10, 0.1, 0.1], 1.0), ([5, 100, 0.01, 1.0], 0.2)]:
        k = np.asarray(fn(a, b, q, r), dtype=float).reshape(1, 4)
        expect(np.max(np.abs(np.linalg.eigvals(a - b @ k))) < 1, f"the gain for Q={q}, R={r} is not stabilising")
        expected, _, _ = control.dlqr(a, b, np.diag(q), [[r]])
        expect(np.allclose(k, expected, rtol=1e-6), f"the gain for Q={q}, R={r} differs from dlqr's")


@poles.test(points=1, hidden=True, hint="Return all four eigenvalues, complex ones included.")
def complex_poles_kept(fn, rng):
    a = np.array([[0.9, 0.5, 0, 0], [-0.5, 0.9, 0, 0], [0, 0, 0.5, 0], [0, 0, 0, 0.2]])
    b = np.array([[0.0], [1.0], [0.0], [0.0]])
    k = np.zeros((1, 4))
    got = np.sort_complex(np.asarray(fn(a, b, k), dtype=complex).reshape(-1))
    expect(np.allclose(got, np.sort_complex(np.linalg.eigvals(a))), "with K = 0 the poles are A's eigenvalues")
