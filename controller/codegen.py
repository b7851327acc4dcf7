"""Generated C code compiled once and cached on disk, and compiled functions called on numpy
arrays without conversions."""

from __future__ import annotations

import hashlib
import os
import subprocess
import tempfile
from collections.abc import Callable, Sequence
from pathlib import Path

import casadi as ca
import numpy as np

CACHE = Path(os.environ.get("UVMS_CODEGEN_CACHE", Path.home() / ".cache" / "uvms-codegen"))


GCC = ("gcc", "-O1", "-fPIC", "-shared")


def compiled(functions: list[ca.Function], name: str) -> dict[str, ca.Function]:
    """The functions compiled to one shared object (gcc -O1), cached on disk (`compiled_lazily`)."""
    return compiled_lazily(name, [f.name() for f in functions], functions, lambda: functions)


def compiled_lazily(name: str, names: Sequence[str], sources: Sequence[ca.Function],
                    derive: Callable[[], list[ca.Function]], recipe: str = "") -> dict[str, ca.Function]:
    """The functions `names`, made by `derive()` from `sources`, compiled to one shared object and
    cached on disk under a hash of the sources' serialized definitions, of `recipe` (how derive
    makes them: e.g. its source code), of CasADi's version and of the compiler's flags. `derive`
    (symbolic derivatives, code generation: about 1 s for a mode's stage functions) runs only on a
    cache miss; a hit costs the serialization (about 10 ms)."""
    digest = hashlib.sha256(f"{ca.__version__}|{' '.join(GCC)}|{recipe}|{'|'.join(names)}".encode())
    for f in sources:
        digest.update(f.serialize().encode())
    key = digest.hexdigest()[:16]
    CACHE.mkdir(parents=True, exist_ok=True)
    so = CACHE / f"{name}_{key}.so"
    if not so.exists():
        functions = derive()
        if [f.name() for f in functions] != list(names):
            raise ValueError(f"derive() made {[f.name() for f in functions]}; allowed: {list(names)}")
        gen = ca.CodeGenerator(f"{name}.c", {"with_header": False})
        for f in functions:
            gen.add(f)
        with tempfile.TemporaryDirectory() as tmp:
            gen.generate(f"{tmp}{os.sep}")
            tmp_so = so.with_suffix(f".{os.getpid()}.tmp")
            subprocess.run([*GCC, str(Path(tmp, f"{name}.c")), "-o", str(tmp_so)], check=True)
        tmp_so.replace(so)  # atomic: parallel runs never load a half-written file
    # finite differences only so that CasADi can build (never evaluate) derivative functions
    return {n: ca.external(n, str(so), {"enable_fd": True}) for n in names}


class NumpyCall:
    """A CasADi Function evaluated on numpy arrays through Function.buffer: inputs and outputs
    in CasADi's nonzero order (column-major for dense ones), no DM conversions (which cost more
    than the compiled functions themselves at this size)."""

    def __init__(self, f: ca.Function):
        self.f = f
        self._nnz_in = [f.nnz_in(i) for i in range(f.n_in())]
        self._buf, self._run = f.buffer()
        self.out = [np.zeros(f.nnz_out(i)) for i in range(f.n_out())]
        for i, o in enumerate(self.out):
            self._buf.set_res(i, memoryview(o))

    def __call__(self, *args: np.ndarray) -> list[np.ndarray]:
        """The outputs' nonzeros (views of buffers the next call overwrites)."""
        keep = [np.ascontiguousarray(a, float) for a in args]  # alive until the call returns
        for i, a in enumerate(keep):
            if a.size != self._nnz_in[i]:
                raise ValueError(f"{self.f.name()} input {i}: {a.size} values; allowed: {self._nnz_in[i]}")
            self._buf.set_arg(i, memoryview(a))
        self._run()
        return self.out
