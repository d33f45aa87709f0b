"""The field route's shortcuts give the same numbers: Jacobian columns that integrate only
the springs they move, the family chosen before the ensemble is drawn, one BLAS thread."""

from __future__ import annotations

import numpy as np
import pytest

from pier_monitor.bench import _field_window, field_case
from pier_monitor.core._blas import _setters, single_blas_thread
from pier_monitor.core.identify.field import (_COLUMNS, FieldSettings, _FieldProblem,
                                              _JointResiduals, fit_field)
from pier_monitor.core.identify.field_families import (_NT, _HeldResiduals, _starts,
                                                       _TakedaField)
from pier_monitor.core.identify.methods import IdentifySettings, identify
from pier_monitor.core.synthetic.field import field_case_recording


@pytest.fixture(scope="module")
def sparse_window():
    return field_case("edefense", "sparse", False, "strong", 1)[0]


def _problem(window):
    pb = _FieldProblem(window, FieldSettings())
    d = window.design
    pb.set_prior(np.column_stack([np.log(d.k1), np.log(np.clip(d.k2 / d.k1, 1e-3, 0.5)),
                                  np.zeros(pb.n), np.log(d.c), np.zeros(pb.n)]))
    return pb


def test_a_jacobian_column_of_the_joint_fit_is_the_full_evaluation(sparse_window):
    """A finite-difference point that moves one spring parameter, or one gain, gives the
    very residuals of a full evaluation, though it integrates only the springs it moves."""
    pb = _problem(sparse_window)
    n = pb.n
    p = pb.prior_mean.copy()
    p[:, 2] = np.log(0.8 * pb.f_max)
    z = np.r_[p.ravel(), np.full(pb.acc.size, 0.002)]
    res = _JointResiduals(pb)
    res(z)
    assert pb.acc.tolist() == [1, 3]
    for col in (0, 2 * _COLUMNS + 2, _COLUMNS * n, _COLUMNS * n + 1):  # springs 1, 3; gains
        z1 = z.copy()
        z1[col] += 1e-3
        short = res._moved_spring(z1)
        assert short is not None
        full = pb.residual(z1[:_COLUMNS * n].reshape(n, _COLUMNS), z1[_COLUMNS * n:])
        np.testing.assert_array_equal(short, full)
        assert np.any(short != res(z))  # the column moves the residuals
        res(z)
    # a point that moves two parameters is evaluated in full
    z2 = z.copy()
    z2[[0, 5]] += 1e-3
    assert res._moved_spring(z2) is None
    np.testing.assert_array_equal(res.map(None, [z2])[0], res(z2))


def test_a_jacobian_column_of_the_takeda_yield_test_is_the_full_evaluation():
    syn = field_case_recording("edefense", "accel", False, "strong", 0, hysteresis="takeda")
    window = _field_window(syn, "edefense/accel/strong/0/takeda")[0]
    pb = _problem(window)
    tf = _TakedaField(pb, window)
    q = _starts(pb.n, np.ones(pb.n), tf.c_ref)[0]
    eps = np.zeros(pb.acc.size)
    g = pb.moments(eps)
    theta, moment = tf.angles(q, g)
    free = [0, 1, 2]
    held = _HeldResiduals(tf, q, eps, 1, free, g, theta, moment,
                          1.05 * float(np.abs(theta[:, 1]).max()))
    x0 = q[free].ravel()
    r0 = held(x0)
    for col in (_NT - 1, _NT + 2, 3 * _NT - 1):  # log c of springs 1 and 3, my of 2
        x1 = x0.copy()
        x1[col] -= 1e-3
        short = held.map(None, [x1])[0]
        assert np.any(short != r0)
        np.testing.assert_array_equal(short, held(x1))
        held(x0)


def test_the_ensemble_is_drawn_only_when_asked_after_the_fit(sparse_window):
    seen = []
    fit = fit_field(sparse_window, members=4, seed=1,
                    members_if=lambda f: seen.append(f) or False)
    assert fit.members is None and len(seen) == 1 and seen[0].members is None
    alone = fit_field(sparse_window, members=1, seed=1)
    np.testing.assert_array_equal(fit.theta, alone.theta)
    np.testing.assert_array_equal(fit.params.k1, alone.params.k1)
    kept = fit_field(sparse_window, members=4, seed=1, members_if=lambda f: True)
    assert kept.members is not None and kept.members.params.shape[0] == 4
    np.testing.assert_array_equal(kept.theta, alone.theta)


def test_no_bilinear_members_are_drawn_where_the_takeda_family_is_chosen():
    syn = field_case_recording("edefense", "accel", False, "strong", 0, hysteresis="takeda")
    window = _field_window(syn, "edefense/accel/strong/0/takeda")[0]
    run = identify(window, IdentifySettings(seed=0, members=4))
    assert run.result.family["family"] == "takeda"
    # no member histories: the four members are draws of the Takeda's posterior
    assert run.members is None and run.result.members == 4


def test_one_blas_thread_inside_the_previous_count_after(monkeypatch):
    setters = _setters()
    if not setters:
        pytest.skip("no OpenBLAS with openblas_set_num_threads_local loaded")
    monkeypatch.delenv("OPENBLAS_NUM_THREADS", raising=False)
    monkeypatch.delenv("OMP_NUM_THREADS", raising=False)
    before = [s(1) for s in setters]
    for s, b in zip(setters, before):
        s(b)

    @single_blas_thread
    def inside():
        counts = [s(1) for s in setters]
        a = np.random.default_rng(0).standard_normal((300, 20))
        return counts, np.linalg.svd(a, compute_uv=False)

    @single_blas_thread
    def nested():  # fit_field_families runs inside fit_field
        return inside()

    for call in (inside, nested):
        counts, sv = call()
        assert counts == [1] * len(setters)
        after = [s(1) for s in setters]
        for s, b in zip(setters, after):
            s(b)
        assert after == before
    np.testing.assert_allclose(
        sv, np.linalg.svd(np.random.default_rng(0).standard_normal((300, 20)),
                          compute_uv=False), rtol=1e-12)
