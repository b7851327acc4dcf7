"""Compiling ahead: the on-disk cache under concurrent builders, and `uvms build`'s pieces."""

from __future__ import annotations

import multiprocessing
import os
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np

CHILD = """
import sys, casadi as ca, numpy as np
from controller import codegen
x = ca.SX.sym("x", 3)
f = ca.Function("race_probe", [x], [ca.sin(x) * ca.exp(x[0]) + x[1] ** 3])
g = codegen.compiled([f], "race_probe")["race_probe"]
print(repr(np.asarray(g([0.3, -0.2, 1.1])).ravel().tolist()))
"""


def test_two_processes_compiling_the_same_function_share_one_sound_cache(tmp_path) -> None:
    """Two processes compile the same new function into an empty cache at the same time: both load a
    working shared object (each writes its own temporary file and renames it into place
    atomically), and the cache ends with exactly one .so and no temporary files. Oracle: CasADi's
    own interpreted evaluation of the function, to 1e-12."""
    import casadi as ca

    env = {**os.environ, "UVMS_CODEGEN_CACHE": str(tmp_path)}
    procs = [subprocess.Popen([sys.executable, "-c", CHILD], env=env, stdout=subprocess.PIPE, text=True,
                              cwd=Path(__file__).parent.parent) for _ in range(2)]
    outs = [p.communicate(timeout=300)[0] for p in procs]
    assert all(p.returncode == 0 for p in procs)
    x = ca.SX.sym("x", 3)
    f = ca.Function("race_probe", [x], [ca.sin(x) * ca.exp(x[0]) + x[1] ** 3])
    expected = np.asarray(f([0.3, -0.2, 1.1])).ravel()
    for out in outs:
        np.testing.assert_allclose(eval(out.strip().splitlines()[-1]), expected, atol=1e-12)
    assert len(list(tmp_path.glob("*.so"))) == 1 and not list(tmp_path.glob("*.tmp"))


def test_pieces_are_shared_between_scenarios_with_the_same_vehicle_and_planes() -> None:
    """Every wall scenario of the default scene with the default arm needs the same compiled pieces
    (Mode I, the certificate, Modes II and III per plane, the model's functions): seven for the
    switching preset; the braking baseline adds none (it uses the model's functions only); a
    scenario with its own planes needs its own Modes but not the model's functions again."""
    from validation import precompile
    from validation.scenarios import get

    headon, oblique, yawed = get("wall-headon"), get("wall-oblique"), get("wall-yawed-cross-current")
    one = precompile.pieces([headon], ["switching"])
    assert sorted(p.kind for p in one) == ["certificate", "mode1", "mode2", "mode2", "mode3", "mode3", "model"]
    assert len(precompile.pieces([headon, oblique], ["switching", "braking"])) == len(one)
    assert len(precompile.pieces([headon, yawed], ["switching"])) == 2 * len(one) - 1


def test_build_marks_what_it_built_and_skips_it_after(tmp_path, monkeypatch) -> None:
    """`build` compiles what is not marked built (in a worker process) and marks it; asked again it
    starts no worker and builds nothing."""
    from validation import precompile
    from validation.scenarios import get

    monkeypatch.setattr(precompile, "_marker", lambda k: tmp_path / k)
    sc = replace(get("avoid-wall"), duration=0.1)
    assert precompile.build([sc], ["braking"], workers=1, quiet=True) == 1
    assert precompile.build([sc], ["braking"], workers=1, quiet=True) == 0
    assert multiprocessing.get_start_method(allow_none=True) in (None, "fork", "spawn", "forkserver")
