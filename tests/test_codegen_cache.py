"""The on-disk cache of compiled code (controller.codegen.compiled_lazily) must never hand back code
compiled from other definitions: a stale library would silently give another model's physics."""

from __future__ import annotations

import casadi as ca
import numpy as np

from controller import codegen


def test_cache_hits_only_the_same_definitions(tmp_path, monkeypatch) -> None:
    """f(x) = k sin(x) with k = 2, then 3, then 2 again, into an empty cache. Oracle: the closed form
    of its derivative, k cos(x), against the loaded library at x = 0.7. The derivation (and code
    generation) runs for each new definition and not for a repeated one."""
    monkeypatch.setattr(codegen, "CACHE", tmp_path)
    x = ca.SX.sym("x")
    derived = []

    def library(k: float) -> ca.Function:
        source = ca.Function("f", [x], [k * ca.sin(x)])

        def derive() -> list[ca.Function]:
            derived.append(k)
            return [ca.Function("cache_test_df", [x], [ca.jacobian(source(x), x)])]

        return codegen.compiled_lazily("cache_test", ["cache_test_df"], [source], derive)["cache_test_df"]

    for k in (2.0, 3.0, 2.0):
        # (libm's cos and numpy's may differ in the last bit)
        assert abs(float(library(k)(0.7)) - k * np.cos(0.7)) < 1e-12
    assert derived == [2.0, 3.0]
    assert len(list(tmp_path.glob("cache_test_*.so"))) == 2
