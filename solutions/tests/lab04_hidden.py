"""Hidden tests for lab 04 (instructor material: never copied into labs/)."""

import math

import control
import numpy as np

from pendkit.control.model import FurutaModel, discretise
from pendkit.grading import expect, task
from pendkit.grading.core import Failed, is_real, shown
from pendkit.grading.prelab import prelab_answers
from pendkit.grading.suites.lab04 import _pair, gain_note, matrices_message
from pendkit.rig import RigParams

GROWTH_PER_STEP, STEPS_TO_TENFOLD = 1.3498588075760032, 7.675283643313486  # e^0.3, ln 10 / 0.3
gain = task("04.lqr_gain", function="lqr_gain", title="A discrete LQR gain")
poles = task("04.closed_loop_poles", function="closed_loop_poles", title="Closed-loop poles")


@gain.test(points=1, hidden=True, hint="Two other sets of weights, on another servo's rig.")
def stabilises_other_weights(fn, rng):
    system = discretise(FurutaModel.from_rig(RigParams.preset("turnigy-tgy-wp23")).linearise("upright"), 0.06)
    a, b = np.asarray(system.A), np.asarray(system.B)
    for q, r in [([1, 10, 0.1, 0.1], 1.0), ([5, 100, 0.01, 1.0], 0.2)]:
        k = np.asarray(fn(a, b, q, r), dtype=float).reshape(1, 4)
        expected, _, _ = control.dlqr(a, b, np.diag(q), [[r]])
        largest = float(np.max(np.abs(np.linalg.eigvals(a - b @ k))))
        what = f"is not stabilising (its largest pole magnitude is {largest:.3f})" if largest >= 1 else \
            "differs from dlqr's"
        expect(largest < 1 and np.allclose(k, expected, rtol=1e-6),
               f"the gain for Q={q}, R={r} {what}: expected {np.array2string(np.asarray(expected), precision=4)}, "
               f"got {np.array2string(k, precision=4)}" + gain_note(a, b, q, r, k))


@poles.test(points=1, hidden=True, hint="Return all four eigenvalues, complex ones included.")
def complex_poles_kept(fn, rng):
    a = np.array([[0.9, 0.5, 0, 0], [-0.5, 0.9, 0, 0], [0, 0, 0.5, 0], [0, 0, 0, 0.2]])
    b = np.array([[0.0], [1.0], [0.0], [0.0]])
    k = np.zeros((1, 4))  # K = 0 on purpose: this test is about complex poles only (A + B K is another test's)
    got = np.sort_complex(np.asarray(fn(a, b, k), dtype=complex).reshape(-1))
    expect(np.allclose(got, np.sort_complex(np.linalg.eigvals(a))), "with K = 0 the poles are A's eigenvalues")


matrices = task("04.upright_matrices", function="upright_matrices", title="The linearisation about upright")


@matrices.test(points=1, hidden=True, hint="The matrices follow the model's fields for any rig.")
def random_rigs(fn, rng):
    for _ in range(3):
        params = RigParams(tip_mass_kg=float(rng.uniform(0.005, 0.03)), dowel_length_m=float(rng.uniform(0.25, 0.5)),
                           arm_mass_kg=float(rng.uniform(0.08, 0.2)))
        model = FurutaModel.from_rig(params)
        reference = model.linearise("upright")
        a, b = _pair(fn(model), "upright_matrices(model)")
        expect(np.allclose(a, np.asarray(reference.A), rtol=1e-6, atol=1e-9)
               and np.allclose(b.reshape(4, 1), np.asarray(reference.B), rtol=1e-6, atol=1e-9),
               matrices_message(model, a, b, f"for a rig with a {1000 * params.tip_mass_kg:.1f} g tip and a "
                                f"{1000 * params.dowel_length_m:.0f} mm dowel"))


prelab_answers("04", {"growth_per_step": GROWTH_PER_STEP}, how={
    "growth_per_step": "a tilt grows as e^(5 t); over one step, t = 0.06 s: e^(5 × 0.06) = e^0.3 ≈ 1.35"})
prelab = task("04.prelab", function="prelab", title="Pre-lab questions")


@prelab.test(points=1, hidden=True, hint="Work it out from the lab's background section.")
def steps_to_tenfold(fn, rng):
    """Right, or right from the student's own growth_per_step (ln 10 / ln growth): a slip in question 1 that
    question 2 carries on rightly is charged once, to question 1 (the lab's pre-lab says so)."""
    answers = fn()
    if not isinstance(answers, dict):
        raise Failed(f"prelab() should return a dict of answers, got {type(answers).__name__}")
    answer, growth = answers.get("steps_to_tenfold"), answers.get("growth_per_step")
    own = math.log(10) / math.log(growth) if is_real(growth) and math.isfinite(growth) and growth > 1 else None
    for expected in (STEPS_TO_TENFOLD, own):
        if expected is not None and is_real(answer) and abs(answer - expected) <= 0.01 * expected:
            return
    message = (f"prelab()['steps_to_tenfold'] should be {STEPS_TO_TENFOLD:.4g}, got {shown(answer)}: n steps multiply "
               "it by 1.35^n = 10: n = ln 10 / ln 1.35 = 2.303 / 0.3 ≈ 7.68")
    if own is not None and abs(growth - GROWTH_PER_STEP) > 0.01 * GROWTH_PER_STEP:
        message += (f" (from your growth_per_step of {growth:.4g}, ln 10 / ln {growth:.4g} = {own:.4g} would count "
                    "too: that slip is charged to question 1 only)")
    raise Failed(message, hint=False)


# --- The answer key (tests/grading/test_wrong_answers.py grades each through the tests above): a correct
# answer per task, which gets full marks, and plausible mistakes, each with words its feedback must contain.


def upright_matrices_with(model, gravity_sign=1.0, coupling=True, coupling_sign=-1.0, arm_damping=True):
    off_diagonal = coupling_sign * model.coupling_kg_m2 if coupling else 0.0
    mass = np.array([[model.arm_inertia_kg_m2, off_diagonal], [off_diagonal, model.pendulum_inertia_kg_m2]])
    damping = model.servo_kv_n_m_s_per_rad + (model.arm_damping_n_m_s_per_rad if arm_damping else 0.0)
    forces = np.array([
        [-model.servo_kp_n_m_per_rad, 0, -damping, 0],
        [0, gravity_sign * model.gravity_torque_n_m, 0, -model.pendulum_damping_n_m_s_per_rad]])
    a = np.zeros((4, 4))
    a[0, 2] = a[1, 3] = 1
    a[2:] = np.linalg.inv(mass) @ forces
    b = np.zeros((4, 1))
    b[2:, 0] = np.linalg.inv(mass) @ [model.servo_kp_n_m_per_rad, 0]
    return a, b


def upright_matrices_b_without_inverse(model):
    a, b = upright_matrices_with(model)
    b[2:, 0] = [model.servo_kp_n_m_per_rad, 0.0]
    return a, b


def upright_matrices_copied(model, **slip):
    """The kit's own model's matrices whatever the model (numbers copied from a first run), with a slip or not."""
    return upright_matrices_with(FurutaModel.from_rig(), **slip)


CORRECT = {
    "04.upright_matrices": lambda model: tuple(np.asarray(m) for m in (model.linearise("upright").A,
                                                                        model.linearise("upright").B)),
    "04.lqr_gain": lambda a, b, q, r: np.asarray(control.dlqr(a, b, np.diag(q), [[r]])[0]),
    "04.closed_loop_poles": lambda a, b, k: np.linalg.eigvals(a - b @ k),
}

MISTAKES = [
    ("04.upright_matrices", lambda model: upright_matrices_with(model, gravity_sign=-1.0), "gravity column has the "
     "wrong sign", {"match_the_linearisation", "random_rigs"}),
    ("04.upright_matrices", lambda model: upright_matrices_with(model, coupling=False), "coupling"),
    ("04.lqr_gain", lambda a, b, q, r: np.asarray(control.lqr(a, b, np.diag(q), [[r]])[0]), "continuous-time"),
    ("04.lqr_gain", lambda a, b, q, r: -np.asarray(control.dlqr(a, b, np.diag(q), [[r]])[0]), "wrong sign"),
    ("04.closed_loop_poles", lambda a, b, k: np.linalg.eigvals(a + b @ k), "A + B K"),
    ("04.upright_matrices", lambda model: upright_matrices_with(model, coupling_sign=1.0), "coupling's sign"),
    ("04.upright_matrices", lambda model: upright_matrices_with(model, arm_damping=False), "back-EMF"),
    ("04.upright_matrices", upright_matrices_b_without_inverse, "without M^-1",
     {"match_the_linearisation", "random_rigs"}),
    ("04.lqr_gain", lambda a, b, q, r: -np.asarray(control.dlqr(a, b, np.diag(q), [[r]])[0]), "wrong sign",
     {"matches_dlqr", "stabilises_other_weights"}),
    ("04.lqr_gain", lambda a, b, q, r: np.asarray(control.lqr(a, b, np.diag(q), [[r]])[0]), "continuous-time",
     {"matches_dlqr", "stabilises_other_weights"}),
    ("04.closed_loop_poles", lambda a, b, k: np.abs(np.linalg.eigvals(np.asarray(a) - np.asarray(b) @ k)),
     "magnitudes"),
    ("04.upright_matrices", upright_matrices_copied, "read every number from the model", {"follows_the_parameters"}),
    ("04.upright_matrices", lambda model: upright_matrices_copied(model, coupling_sign=1.0), "do not change with the "
     "model", {"follows_the_parameters"}),
]
