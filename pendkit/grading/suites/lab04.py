"""Lab 04, LQR balance: public tests."""

from __future__ import annotations

import control
import numpy as np

from pendkit.control.model import FurutaModel, discretise
from pendkit.grading.core import Diagnosis, Failed, NotGradable, expect, is_sequence_of, task
from pendkit.grading.prelab import prelab_task
from pendkit.grading.written import written
from pendkit.rig import RigParams

matrices = task("04.upright_matrices", function="upright_matrices", title="A and B about upright", hidden_points=1)
gain = task("04.lqr_gain", function="lqr_gain", title="A discrete LQR gain", hidden_points=1)
poles = task("04.closed_loop_poles", function="closed_loop_poles", title="Closed-loop poles", hidden_points=1)


def _reference(model: FurutaModel):
    system = model.linearise("upright")
    return np.asarray(system.A), np.asarray(system.B)


def _variant(model: FurutaModel, coupling_sign: float = -1.0, arm_damping: bool = True, gravity_sign: float = 1.0,
             coupling: bool = True, b_through_m: bool = True):
    """A and B as the lab's derivation gives them (the defaults), or with one common slip: the coupling's sign
    about upright (cos(pi) = -1), the arm's back-EMF damping left out, gravity's sign (the hanging model), the
    coupling left out of M, or B's lower half without M^-1."""
    off_diagonal = coupling_sign * model.coupling_kg_m2 if coupling else 0.0
    mass = np.array([[model.arm_inertia_kg_m2, off_diagonal], [off_diagonal, model.pendulum_inertia_kg_m2]])
    damping = model.servo_kv_n_m_s_per_rad + (model.arm_damping_n_m_s_per_rad if arm_damping else 0.0)
    forces = np.array([[-model.servo_kp_n_m_per_rad, 0.0, -damping, 0.0],
                       [0.0, gravity_sign * model.gravity_torque_n_m, 0.0, -model.pendulum_damping_n_m_s_per_rad]])
    inverse = np.linalg.inv(mass)
    a = np.zeros((4, 4))
    a[0, 2] = a[1, 3] = 1.0
    a[2:] = inverse @ forces
    b = np.zeros((4, 1))
    b[2:, 0] = (inverse if b_through_m else np.eye(2)) @ np.array([model.servo_kp_n_m_per_rad, 0.0])
    return a, b


# the derivation (no slip) and each slip `matrices_note` names: follows_the_parameters judges whether the matrices
# follow the model's fields whichever of these the student's kit-model answer is
DERIVATIONS = ({}, {"coupling_sign": 1.0}, {"arm_damping": False}, {"gravity_sign": -1.0}, {"coupling": False},
               {"b_through_m": False})


def _same(pair, reference) -> bool:
    return all(np.allclose(x, y, rtol=1e-6, atol=1e-9) for x, y in zip(pair, reference))


def _pair(got, name: str):
    if not is_sequence_of(got, 2):
        raise Failed(f"{name} should return a pair (A, B), got {type(got).__name__}")
    a, b = (np.asarray(x, dtype=float) for x in got)
    expect(a.shape == (4, 4) and b.reshape(-1).shape == (4,), f"A should be 4x4 and B 4x1, got {a.shape} and "
           f"{b.shape}")
    return a, b.reshape(4, 1)


@matrices.test(points=3, hint="Solve M [phi'', theta''] = forces: both rows of A's lower half come from M^-1.")
def match_the_linearisation(fn, rng):
    model = FurutaModel.from_rig()
    a, b = _pair(fn(model), "upright_matrices(model)")
    ref_a, ref_b = _reference(model)
    expect(np.allclose(a, ref_a, rtol=1e-6, atol=1e-9) and np.allclose(b, ref_b, rtol=1e-6, atol=1e-9),
           matrices_message(model, a, b, "about upright"))


def matrices_message(model: FurutaModel, a: np.ndarray, b: np.ndarray, where: str) -> str:
    """Which of A and B differ from the linearisation (`where`: the rig's words), the first lower-half row that
    does, expected and got, and the slip's cause when it is a known one."""
    ref_a, ref_b = _reference(model)
    b = np.asarray(b, dtype=float).reshape(4, 1)
    wrong_a = not np.allclose(a, ref_a, rtol=1e-6, atol=1e-9)
    wrong_b = not np.allclose(b, ref_b, rtol=1e-6, atol=1e-9)
    name, want, got = ("A", ref_a, a) if wrong_a else ("B", ref_b.T, b.T)
    row = next((i for i in range(len(want)) if not np.allclose(got[i], want[i], rtol=1e-6, atol=1e-9)), 0)
    shown_row = f"{name}[{row}]" if name == "A" else "B"
    message = (f"{' and '.join(m for m, w in (('A', wrong_a), ('B', wrong_b)) if w)} differ"
               f"{'' if wrong_a and wrong_b else 's'} from the linearisation {where}: {shown_row} should be "
               f"{np.array2string(want[row], precision=4)}, got {np.array2string(got[row], precision=4)}")
    return message + matrices_note(model, a, b)


def matrices_note(model: FurutaModel, a: np.ndarray, b: np.ndarray) -> str:
    """Which common slip makes `upright_matrices`' (a, b) for `model` differ from the linearisation, if any."""
    ref_a, ref_b = _reference(model)
    b = np.asarray(b, dtype=float).reshape(4, 1)
    if np.allclose(a, ref_a, rtol=1e-6, atol=1e-9) and np.allclose(b[2:, 0], [model.servo_kp_n_m_per_rad, 0.0]):
        return Diagnosis(": A is right; B's lower half is [kp, 0] without M^-1: like A's, it is M^-1 [kp, 0], so "
                         "the pendulum's row is not 0")
    if np.allclose(a[2:, 1], -ref_a[2:, 1], rtol=1e-3) and not np.allclose(a[2:, 1], ref_a[2:, 1], rtol=1e-3):
        return Diagnosis(": the gravity column has the wrong sign (upright is unstable: gravity pushes away from it)")
    if abs(a[2, 1]) < 1e-9 and abs(ref_a[2, 1]) > 1e-3:
        return Diagnosis(": the arm row has no gravity term; you left out the coupling through the mass matrix")
    if _same((a, b), _variant(model, coupling_sign=1.0)):
        return Diagnosis(": the coupling's sign: about upright cos(alpha) = -1, so the mass matrix's off-diagonal "
                         "is -m r l")
    if _same((a, b), _variant(model, arm_damping=False)):
        return Diagnosis(": the arm's damping is the servo's kv plus the back-EMF damping (arm_damping_n_m_s_per_rad)")
    if not np.allclose(a[:2], ref_a[:2]):
        return Diagnosis(": the top two rows say that the angles' rates are the rate states")
    return ""


@matrices.test(points=1, hint="Use the model's fields, not numbers copied from the lab.")
def follows_the_parameters(fn, rng):
    """Whether the matrices follow the model's fields: judged for the right derivation or one with a slip that
    match_the_linearisation names (that slip is charged there, not here), not for an answer of unknown origin."""
    kit = FurutaModel.from_rig()
    own = _pair(fn(kit), "upright_matrices(model)")
    derivation = next((d for d in DERIVATIONS if _same(own, _variant(kit, **d))), None)
    if derivation is None:
        raise NotGradable("A and B are not right for the kit's own model yet, nor one known slip away from it (see "
                          "match_the_linearisation): this test then tries a heavier pendulum")
    model = FurutaModel.from_rig(RigParams().replace(tip_mass_kg=0.02, pendulum_damping_n_m_s_per_rad=0.004))
    a, b = _pair(fn(model), "upright_matrices(heavier model)")
    where = "for a heavier tip and more damping (read every number from the model)"
    if not derivation:
        expect(_same((a, b), _reference(model)), matrices_message(model, a, b, where))
    else:  # the slip is match_the_linearisation's: here only whether the numbers come from the model
        expect(_same((a, b), _variant(model, **derivation)),
               "A and B do not change with the model: for a heavier tip and more damping they should be your own "
               "derivation on the heavier model's fields (read every number from the model, none copied from the lab)")


def _discrete():
    model = FurutaModel.from_rig()
    system = discretise(model.linearise("upright"), 0.06)
    return np.asarray(system.A), np.asarray(system.B)


@gain.test(points=2, hint="control.dlqr(A, B, Q, R) solves the discrete problem; it returns (K, S, E).")
def matches_dlqr(fn, rng):
    a, b = _discrete()
    q, r = [2.0, 40.0, 0.05, 0.5], 3.0
    expected, _, _ = control.dlqr(a, b, np.diag(q), [[r]])
    got = np.asarray(fn(a, b, q, r), dtype=float).reshape(1, -1)
    expect(got.shape == (1, 4) and np.allclose(got, expected, rtol=1e-6),
           f"K differs from control.dlqr's: expected {np.array2string(np.asarray(expected), precision=4)}, got "
           f"{np.array2string(got, precision=4)}" + gain_note(a, b, q, r, got))


def gain_note(a: np.ndarray, b: np.ndarray, q, r: float, got: np.ndarray) -> str:
    """The cause of a gain that differs from control.dlqr's, named from its value (a `Diagnosis`), or ""."""
    if got.shape != (1, 4):
        return ""
    expected, _, _ = control.dlqr(a, b, np.diag(q), [[r]])
    continuous, _, _ = control.lqr(a, b, np.diag(q), [[r]])
    if np.allclose(got, continuous, rtol=1e-3):
        return Diagnosis(": that is control.lqr, the continuous-time problem; these A, B are discrete (dlqr)")
    if np.allclose(got, -np.asarray(expected), rtol=1e-6):
        return Diagnosis(": right size, wrong sign: dlqr's K is for u = -K x, return it as it is")
    return ""


@poles.test(points=2, hint="The closed loop is x_(k+1) = (A - B K) x_k.")
def eigenvalues_of_the_closed_loop(fn, rng):
    a, b = _discrete()
    k, _, _ = control.dlqr(a, b, np.diag([2.0, 40.0, 0.05, 0.5]), [[3.0]])
    expected = np.sort_complex(np.linalg.eigvals(a - b @ k))
    got = np.sort_complex(np.asarray(fn(a, b, np.asarray(k)), dtype=complex).reshape(-1))
    message = f"expected poles with magnitudes {np.round(np.abs(expected), 3).tolist()}"
    if got.shape == expected.shape and np.allclose(got, np.sort_complex(np.linalg.eigvals(a + b @ k)), atol=1e-9):
        message += ": you used A + B K; the feedback is u = -K x"
    elif got.shape == expected.shape and np.allclose(np.sort(got.real), np.sort(np.abs(expected)), atol=1e-9) \
            and np.allclose(got.imag, 0):
        message += ": those are the poles' magnitudes; return the eigenvalues themselves (complex where they are)"
    expect(got.shape == expected.shape and np.allclose(got, expected, atol=1e-9), message)


prelab_task("04", ("growth_per_step", "steps_to_tenfold"))

written("04.reflection", "Reflection", points=3)
