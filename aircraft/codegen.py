"""Compile CasADi functions to C once and cache the shared library (the plant's RK4 step, later the MPC).

The plant's step costs 15 us in CasADi's virtual machine and 2 us compiled (docs/performance.md). The
library is keyed by a hash of the generated C, so a different airframe or model gives a different file;
it is built with `cc -O2 -ffp-contract=off` (no fused multiply-add, so results match the VM bit for bit)
into $TILTROTOR_SITL_CACHE or ~/.cache/tiltrotor-sitl, written atomically. Without a C compiler the
uncompiled Function is used and a one-line notice says so.
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

COMPILE_FLAGS = ("-O2", "-ffp-contract=off", "-fPIC", "-shared")


def cache_directory() -> Path:
    root = os.environ.get("TILTROTOR_SITL_CACHE")
    return Path(root) if root else Path.home() / ".cache" / "tiltrotor-sitl"


def compiled(function: ca.Function, who: str = "tiltrotor-sitl") -> ca.Function:
    """The same function backed by generated, compiled C (cached), or `function` itself if that fails."""
    compiler = os.environ.get("CC") or shutil.which("cc") or shutil.which("gcc")
    if compiler is None:
        print(f"{who}: no C compiler found, {function.name()} runs in CasADi's virtual machine", file=sys.stderr)
        return function
    with tempfile.TemporaryDirectory() as scratch:
        source_name = f"{function.name()}.c"
        generator = ca.CodeGenerator(source_name, {"with_header": False})
        generator.add(function)
        generator.generate(scratch + os.sep)
        source = Path(scratch, source_name).read_bytes()
        digest = hashlib.sha256(source + " ".join(COMPILE_FLAGS).encode()).hexdigest()[:16]
        library = cache_directory() / f"{function.name()}_{digest}.so"
        if not library.exists():
            try:
                library.parent.mkdir(parents=True, exist_ok=True)
                partial = Path(scratch, library.name)
                subprocess.run(
                    [compiler, *COMPILE_FLAGS, str(Path(scratch, source_name)), "-o", str(partial), "-lm"],
                    check=True, capture_output=True, timeout=300,
                )  # fmt: skip
                staging = library.with_name(f"{library.name}.{os.getpid()}.tmp")
                shutil.copyfile(partial, staging)
                os.replace(staging, library)  # atomic: never a half-written library, even with racing processes
            except (OSError, subprocess.SubprocessError) as exc:
                print(f"{who}: compiling {function.name()} failed ({exc}); using CasADi's VM", file=sys.stderr)
                return function
    return ca.external(function.name(), str(library))
