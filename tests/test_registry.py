"""The registry, plugins through entry-point metadata, and the conformance suite on
every registered estimator (and on broken ones, which it must reject)."""

from __future__ import annotations

import importlib
import sys
import textwrap

import numpy as np
import pytest
from filterpy.common import Saver

from motorid import testing
from motorid.estimators import (
    ARXRLS,
    Basis,
    HammersteinRLS,
    available,
    create,
    factory,
    polynomial,
    register,
    unregister,
)
from motorid.testing import check_estimator, conformance_record

#: keyword arguments that build a small instance of each registered estimator
SMALL = {
    "arx-rls": {"na": 2, "nb": 2, "lam": 0.99},
    "hammerstein-rls": {"na": 2, "nb": 2, "degree": 3, "lam": 0.99},
}


def test_built_ins_are_available_and_created_by_name():
    assert {"arx-rls", "hammerstein-rls"} <= set(available())
    assert isinstance(create("arx-rls", na=1, nb=1), ARXRLS)
    est = create("hammerstein-rls", na=4, nb=4, degree=3, lam=0.99)
    assert isinstance(est, HammersteinRLS) and est.dim_x == 4 + 5 * 3


def test_unknown_name_lists_what_is_available():
    with pytest.raises(ValueError, match=r"unknown estimator 'kalman'.*arx-rls"):
        create("kalman")


@pytest.mark.cpu_sensitive
@pytest.mark.parametrize("name", available())
def test_every_registered_estimator_passes_the_conformance_suite(name):
    """Every registered estimator passes; motorid's own give the sample loop's numbers
    bit for bit from batch_filter, and a reset estimator a fresh one's: their batch
    kernels run the loop's operations in the loop's order on the same basis values."""
    report = check_estimator(lambda: create(name, **SMALL.get(name, {})))
    if factory(name).__module__.startswith("motorid."):
        assert report["check_batch_equals_loop"] == 0.0
        assert report["check_reset"] == 0.0


@pytest.mark.cpu_sensitive
@pytest.mark.parametrize("gamma_method", ["paper", "svd"])
@pytest.mark.parametrize(
    "basis",
    [None, "u,sign", "dead_zone:0.5,u^3", [np.tanh, lambda v: v * np.abs(v)]],
    ids=["cubic", "u,sign", "dead_zone,u^3", "custom"],
)
def test_hammerstein_variants_pass_the_conformance_suite(basis, gamma_method):
    """Every kind of basis, the built-ins compiled and custom NumPy functions, gives
    batch_filter the loop's numbers bit for bit (one evaluation of the basis)."""
    report = check_estimator(lambda: HammersteinRLS(2, 2, basis=basis, gamma_method=gamma_method, lam=0.98))
    assert report["check_batch_equals_loop"] == 0.0


class _LastBitBasis(Basis):
    """Rounds u^3 one unit in the last place up on every third sample of a record but
    not for a single sample, as NumPy's vectorised power can on an AVX-512 CPU."""

    def evaluate(self, u, start=0):
        G = super().evaluate(u, start)
        if len(u) > 1:
            G[::3, 2] = np.nextafter(G[::3, 2], np.inf)
        return G


@pytest.mark.cpu_sensitive
def test_a_plugin_whose_batch_path_rounds_differently_passes():
    """A third-party estimator is not rejected for rounding: its batch path differs from
    its loop in the last bit of one regressor on a third of the samples, which RLS
    amplifies to about 1e-9 of the estimate (more than the former rtol 1e-9 allowed);
    the suite passes it, using a small part of its allowance."""
    u, y = conformance_record()
    make = lambda: HammersteinRLS(4, 4, basis=_LastBitBasis(polynomial(3)), lam=0.99)  # noqa: E731
    loop = make()
    for k in range(len(u)):
        loop.predict(u[k])
        loop.update(y[k])
    batch = make()
    batch.batch_filter(u, y)
    assert np.abs(batch.x - loop.x).max() > 1e-12 * np.abs(loop.x).max()  # they do differ
    figure = check_estimator(make)["check_batch_equals_loop"]
    assert 0.0 < figure < 0.1


class _DriftingBatch(ARXRLS):
    """Broken: its batch path disagrees with its sample loop."""

    def batch_filter(self, u, z, saver=None):
        result = super().batch_filter(u, z, saver)
        self.x = self.x + 1e-3
        return result


class _TouchesPOnBadInput(ARXRLS):
    """Broken: changes P before it checks the input."""

    def predict(self, u):
        self.P = self.P * 1.001
        return super().predict(u)


class _ForgetsDifferently(ARXRLS):
    """Broken: its batch path applies a forgetting factor off by one part in a million."""

    def batch_filter(self, u, z, saver=None):
        lam = self._lam  # the factor in use (lam as resolved by reset())
        self._lam = lam * (1.0 - 1e-6)
        try:
            return super().batch_filter(u, z, saver)
        finally:
            self._lam = lam


class _AsymmetricP(ARXRLS):
    """Broken: loses the symmetry of P."""

    def batch_filter(self, u, z, saver=None):
        result = super().batch_filter(u, z, saver)
        self.P = self.P + np.triu(np.full_like(self.P, 1e-9), 1)
        return result


@pytest.mark.cpu_sensitive
@pytest.mark.parametrize(
    ("broken", "check"),
    [
        (_DriftingBatch, "check_batch_equals_loop"),
        (_ForgetsDifferently, "check_batch_equals_loop"),
        (_TouchesPOnBadInput, "check_bad_input"),
        (_AsymmetricP, "check_covariance"),
    ],
)
def test_the_conformance_suite_rejects_broken_estimators(broken, check):
    """Each check fails on the estimator broken its way (and so does the whole suite):
    the allowance for rounding is far below a disagreement of one part in a million."""
    u, y = conformance_record()
    with pytest.raises(AssertionError, match=check):
        getattr(testing, check)(lambda: broken(2, 2, lam=0.99), u, y)
    with pytest.raises(AssertionError):
        check_estimator(lambda: broken(2, 2, lam=0.99))


def test_saver_records_every_attribute_and_property():
    est = create("hammerstein-rls", na=2, nb=2, degree=2)
    u, y = conformance_record(50)
    saver = Saver(est)
    est.batch_filter(u, y, saver=saver)
    saver.to_array()
    assert saver.x.shape == (50, est.dim_x)
    assert saver.P.shape == (50, est.dim_x, est.dim_x)
    assert len(saver.params) == 50 and saver.params[-1]["gamma"].shape == (2,)
    assert np.all(np.asarray(saver.log_likelihood) < 0)


def test_register_at_run_time():
    register("my-arx", lambda **kw: ARXRLS(1, 1, **kw))
    try:
        assert "my-arx" in available()
        assert create("my-arx", lam=0.9).lam == 0.9
        with pytest.raises(ValueError, match="taken"):
            register("arx-rls", ARXRLS)
    finally:
        unregister("my-arx")
    assert "my-arx" not in available()


def test_a_plugin_registered_through_entry_point_metadata(tmp_path, monkeypatch, caplog):
    """An installed distribution declaring the entry point group is found by name,
    built by create() and passes the conformance suite; a broken one is logged and left out."""
    package = tmp_path / "motorid_demo_plugin"
    package.mkdir()
    (package / "__init__.py").write_text(
        textwrap.dedent(
            '''
            from motorid.estimators import ARXRLS

            class FirstOrderRLS(ARXRLS):
                """A first-order ARX model as a third-party estimator."""
                name = "first-order-rls"

                def __init__(self, lam=1.0):
                    super().__init__(1, 1, lam=lam, direct_term=False)
            '''
        )
    )
    dist = tmp_path / "motorid_demo_plugin-1.0.dist-info"
    dist.mkdir()
    (dist / "METADATA").write_text("Metadata-Version: 2.1\nName: motorid-demo-plugin\nVersion: 1.0\n")
    (dist / "entry_points.txt").write_text(
        "[motorid.estimators]\n"
        "first-order-rls = motorid_demo_plugin:FirstOrderRLS\n"
        "broken-plugin = motorid_demo_plugin:DoesNotExist\n"
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    importlib.invalidate_caches()
    try:
        assert "first-order-rls" in available()
        assert "broken-plugin" not in available()
        assert "broken-plugin" in caplog.text
        est = create("first-order-rls", lam=0.97)
        assert type(est).__name__ == "FirstOrderRLS" and est.lam == 0.97
        report = check_estimator(lambda: create("first-order-rls", lam=0.99))
        assert report["check_batch_equals_loop"] == 0.0  # it inherits motorid's batch kernel
    finally:
        sys.modules.pop("motorid_demo_plugin", None)


@pytest.mark.parametrize(
    ("name", "kwargs"),
    [
        ("arx-rls", {"na": 2, "nb": 1, "lam": 0.99}),
        ("arx-rls", {"na": 1, "nb": 1, "max_trace": None, "x0": [0.1, 0.2, 0.3]}),
        ("hammerstein-rls", {"na": 2, "nb": 2, "basis": "u,sign", "gamma_method": "svd"}),
        ("hammerstein-rls", {"na": 1, "nb": 1, "degree": 2, "lam": 0.98}),
        ("friction-ekf", {"nis_window": 7, "stribeck": True}),
    ],
)
def test_get_params_gives_the_arguments_as_given_and_rebuilds_the_same_estimator(name, kwargs):
    """As scikit-learn: the constructor stores its arguments unchanged (a list stays the list,
    None stays None), get_params() gives them, and the class built from them filters a record
    to the same bits."""
    from motorid.estimators.base import constructor_parameters

    est = create(name, **kwargs)
    params = est.get_params()
    assert all(params[key] is value for key, value in kwargs.items())
    if name != "friction-ekf":  # its get_params also names the arguments of the shared base
        assert list(params) == constructor_parameters(type(est))
    twin = type(est)(**params)
    u, y = conformance_record()
    np.testing.assert_array_equal(est.batch_filter(u, y).x, twin.batch_filter(u, y).x)


def test_an_argument_changed_takes_effect_at_reset_where_it_is_checked():
    u, y = conformance_record()
    est = ARXRLS(2, 2, lam=0.99)
    est.lam = 1.5
    with pytest.raises(ValueError, match=r"lam must satisfy 0 < lam <= 1, got 1\.5"):
        est.reset()
    est.lam = 0.9
    est.reset()
    np.testing.assert_array_equal(est.batch_filter(u, y).x, ARXRLS(2, 2, lam=0.9).batch_filter(u, y).x)
    hammerstein = HammersteinRLS(2, 2, degree=2)
    hammerstein.basis = "u,sign"
    with pytest.raises(ValueError, match="give degree or basis, not both"):
        hammerstein.reset()
    hammerstein.degree = None
    hammerstein.reset()
    assert hammerstein.basis_functions.names == ("u", "sign(u)") and hammerstein.n_basis == 2


def test_the_plugins_are_searched_once_for_each_sys_path(monkeypatch, tmp_path):
    """The entry points are read once for a ``sys.path`` (the command line asks for the estimators'
    names three times while it builds its parser) and read again when ``sys.path`` changes, so a
    plugin installed on a new path is found."""
    from importlib.metadata import entry_points

    from motorid.estimators import registry

    searches = []

    def counted(**kwargs):
        searches.append(kwargs)
        return entry_points(**kwargs)

    monkeypatch.setattr(registry, "entry_points", counted)
    monkeypatch.setattr(registry, "_plugin_cache", None)
    names = available()
    assert available() == available() == names
    assert len(searches) == 1
    monkeypatch.syspath_prepend(str(tmp_path))
    assert available() == names
    assert len(searches) == 2
