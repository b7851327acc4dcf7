"""Generated C code compiled once and cached on disk, and compiled functions called on numpy
arrays without conversions."""

from __future__ import annotations

import hashlib
import os
import subprocess
import tempfile
from pathlib import Path

import casadi as ca
import numpy as np

CACHE = Path(os.environ.get("UVMS_CODEGEN_CACHE", Path.home() / ".cache" / "uvms-codegen"))


def compiled(functions: list[ca.Function], name: str) -> dict[str, ca.Function]:
    """The functions compiled to one shared object (gcc -O1), cached by a hash of their C code."""
    gen = ca.CodeGenerator(f"{name}.c", {"with_header": False})
    for f in functions:
        gen.add(f)
    with tempfile.TemporaryDirectory() as tmp:
        cwd = os.getcwd()
        os.chdir(tmp)
        try:
            gen.generate()
            source = Path(tmp, f"{name}.c").read_bytes()
        finally:
            os.chdir(cwd)
    key = hashlib.sha256(source).hexdigest()[:16]
    CACHE.mkdir(parents=True, exist_ok=True)
    so = CACHE / f"{name}_{key}.so"
    if not so.exists():
        c = CACHE / f"{name}_{key}.c"
        c.write_bytes(source)
        tmp_so = so.with_suffix(f".{os.getpid()}.tmp")
        subprocess.run(["gcc", "-O1", "-fPIC", "-shared", str(c), "-o", str(tmp_so)], check=True)
        tmp_so.replace(so)  # atomic: parallel runs never load a half-written file
        c.unlink()
    # finite differences only so that CasADi can build (never evaluate) derivative functions
    return {f.name(): ca.external(f.name(), str(so), {"enable_fd": True}) for f in functions}


class NumpyCall:
    """A CasADi Function evaluated on numpy arrays through Function.buffer: inputs and outputs
    in CasADi's nonzero order (column-major for dense ones), no DM conversions (which cost more
    than the compiled functions themselves at this size)."""

    def __init__(self, f: ca.Function):
        self.f = f
        self._buf, self._run = f.buffer()
        self.out = [np.zeros(f.nnz_out(i)) for i in range(f.n_out())]
        for i, o in enumerate(self.out):
            self._buf.set_res(i, memoryview(o))

    def __call__(self, *args: np.ndarray) -> list[np.ndarray]:
        """The outputs' nonzeros (views of buffers the next call overwrites)."""
        keep = [np.ascontiguousarray(a, float) for a in args]  # alive until the call returns
        for i, a in enumerate(keep):
            if a.size != self.f.nnz_in(i):
                raise ValueError(f"{self.f.name()} input {i}: {a.size} values; allowed: {self.f.nnz_in(i)}")
            self._buf.set_arg(i, memoryview(a))
        self._run()
        return self.out
