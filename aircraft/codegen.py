"""Compile C once and cache the shared library: CasADi functions (the plant's RK4 step, the allocator's model)
and generated C built together with hand-written C (the MPC's QP driver, autopilot/mpc/rti.c).

The plant's step costs 15 us in CasADi's virtual machine and 2 us compiled (docs/design/solver.md). The
library is keyed by a hash of its sources and flags, so a different airframe or model gives a different file;
CasADi functions are built with `cc -O2 -ffp-contract=off` (no fused multiply-add, so results match the VM bit
for bit) into $TILTROTOR_SITL_CACHE or ~/.cache/tiltrotor-sitl, written atomically. Without a C compiler the
caller falls back (the uncompiled Function for `compiled`) and a one-line notice says so.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import casadi as ca
import numpy as np

COMPILE_FLAGS = ("-O2", "-ffp-contract=off", "-fPIC", "-shared")


def cache_directory() -> Path:
    root = os.environ.get("TILTROTOR_SITL_CACHE")
    return Path(root) if root else Path.home() / ".cache" / "tiltrotor-sitl"


def generated_sources(name: str, functions: list[ca.Function], with_header: bool = False) -> dict[str, bytes]:
    """CasADi's C for `functions`, as {file name: contents}: name.c (and name.h with `with_header`)."""
    with tempfile.TemporaryDirectory() as scratch:
        generator = ca.CodeGenerator(f"{name}.c", {"with_header": with_header})
        for function in functions:
            generator.add(function)
        generator.generate(scratch + os.sep)
        return {path.name: path.read_bytes() for path in Path(scratch).iterdir()}


def shared_library(
    name: str,
    sources: dict[str, bytes],
    who: str,
    flags: tuple[str, ...] = COMPILE_FLAGS,
    link: tuple[str, ...] = (),
) -> Path | None:
    """The cached library built from `sources` ({file name: contents}; the .c files are compiled, the others
    are there to be included), or None (with a one-line notice) when there is no compiler or it fails."""
    compiler = os.environ.get("CC") or shutil.which("cc") or shutil.which("gcc")
    if compiler is None:
        print(f"{who}: no C compiler found, {name} is not compiled", file=sys.stderr)
        return None
    digest = hashlib.sha256()
    for file_name in sorted(sources):
        digest.update(file_name.encode() + b"\0" + sources[file_name] + b"\0")
    digest.update(" ".join((*flags, *link)).encode())
    library = cache_directory() / f"{name}_{digest.hexdigest()[:16]}.so"
    if library.exists():
        return library
    with tempfile.TemporaryDirectory() as scratch:
        for file_name, contents in sources.items():
            Path(scratch, file_name).write_bytes(contents)
        c_files = [str(Path(scratch, f)) for f in sorted(sources) if f.endswith(".c")]
        partial = Path(scratch, library.name)
        try:
            library.parent.mkdir(parents=True, exist_ok=True)
            subprocess.run(
                [compiler, *flags, "-I", scratch, *c_files, "-o", str(partial), *link, "-lm"],
                check=True, capture_output=True, timeout=300,
            )  # fmt: skip
            staging = library.with_name(f"{library.name}.{os.getpid()}.tmp")
            shutil.copyfile(partial, staging)
            os.replace(staging, library)  # atomic: never a half-written library, even with racing processes
        except (OSError, subprocess.SubprocessError) as exc:
            detail = (
                exc.stderr.decode(errors="replace")[-300:] if isinstance(exc, subprocess.CalledProcessError) else exc
            )
            print(f"{who}: compiling {name} failed ({detail})", file=sys.stderr)
            return None
    return library


def compiled(function: ca.Function, who: str = "tiltrotor-sitl") -> ca.Function:
    """The same function backed by generated, compiled C (cached), or `function` itself if that fails."""
    library = shared_library(function.name(), generated_sources(function.name(), [function]), who)
    if library is None:
        print(f"{who}: {function.name()} runs in CasADi's virtual machine", file=sys.stderr)
        return function
    return ca.external(function.name(), str(library))


class BufferedFunction:
    """A CasADi Function of dense vectors evaluated on numpy arrays bound once: a call with numpy arguments costs
    ~30-100 us in conversions, this one copies its arguments into the bound inputs and costs a few (docs/design/solver.md,
    "Calling CasADi from Python"). The outputs are the same arrays at every call: copy what you keep."""

    def __init__(self, function: ca.Function) -> None:
        self.inputs = [np.zeros(function.nnz_in(i)) for i in range(function.n_in())]
        self.outputs = [np.zeros(function.nnz_out(i)) for i in range(function.n_out())]
        self._buffer, self._evaluate = function.buffer()
        for index, array in enumerate(self.inputs):
            self._buffer.set_arg(index, memoryview(array))
        for index, array in enumerate(self.outputs):
            self._buffer.set_res(index, memoryview(array))

    def __call__(self, *arguments: np.ndarray) -> list[np.ndarray]:
        for bound, argument in zip(self.inputs, arguments, strict=True):
            bound[:] = argument
        self._evaluate()
        return self.outputs
