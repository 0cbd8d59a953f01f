"""The MPC's QP solved by HPIPM through its OCP-QP C interface: one C call per real-time iteration.

autopilot/mpc/rti.c evaluates the CasADi-generated stage functions, writes each stage's blocks into HPIPM's
structures and runs HPIPM's interior-point method; this module builds it (with aircraft/codegen.py's cache,
linked against the HPIPM and BLASFEO that the casadi wheel ships) and calls it through ctypes, which releases the
GIL during the call: `solve` (one QP), `iterate` (a tick's Gauss-Newton steps), and `start` / `finish` (the same
steps on the C object's worker thread, docs/mpc.md, options). Building returns None where there is no C compiler; the
caller then uses CasADi's `conic`.
"""

from __future__ import annotations

import ctypes
import dataclasses
import enum
from dataclasses import dataclass
from pathlib import Path

import casadi as ca
import numpy as np

from aircraft.codegen import generated_sources, shared_library
from autopilot.mpc.model import NP, NU, NX, PSI_D_INDEX, PSI_INDEX
from autopilot.mpc.qp import StageFunctions

HPIPM_STATUS = {0: "SUCCESS", 1: "MAX_ITER", 2: "MIN_STEP", 3: "NAN_SOL", 4: "INCONS_EQ"}
CASADI_DIRECTORY = Path(ca.__file__).parent
COMPILE_FLAGS = ("-O3", "-fPIC", "-shared", "-I", str(CASADI_DIRECTORY / "include"))
LINK_FLAGS = ("-L", str(CASADI_DIRECTORY), "-lhpipm", "-lblasfeo", f"-Wl,-rpath,{CASADI_DIRECTORY}", "-pthread")


class HpipmMode(enum.IntEnum):
    """HPIPM's `enum hpipm_mode`."""

    SPEED_ABS = 0
    SPEED = 1
    BALANCE = 2
    ROBUST = 3


@dataclass(frozen=True)
class HpipmSettings:
    """HPIPM's interior-point settings; the tolerances are its stationarity, equality, inequality and
    complementarity residuals. warm_start: 0 cold, 1 from the previous QP's primal solution, 2 primal and dual
    (after a failed solve the next one starts cold).
    ric_alg (0 classical Riccati, 1 square root), pred_corr (0/1), mu0: None keeps the mode's default.
    residual_exit: stop only when the residuals meet the tolerances too (speed_abs alone stops on the duality
    measure). A warm start from the previous QP's duals (2) stops early either way: iterated, it settles 1.5e-4
    off the NLP's optimum (cold or primal: 8.6e-6).
    mu0_warm: the initial barrier parameter of a warm-started solve after one that took at most 2 iterations
    (None: always the mode's mu0). From the previous plan the IPM then converges in one iteration instead of
    two; after a harder solve (bounds becoming active) the mode's mu0 is kept, where a low start takes many
    short steps."""

    mode: HpipmMode = HpipmMode.SPEED_ABS
    iter_max: int = 50
    tol_stat: float = 1e-5
    tol_eq: float = 1e-7
    tol_ineq: float = 1e-7
    tol_comp: float = 1e-7
    warm_start: int = 1
    ric_alg: int | None = None
    pred_corr: int | None = None
    mu0: float | None = None
    residual_exit: bool = True
    mu0_warm: float | None = 1e-3

    @staticmethod
    def for_tolerance(tolerance: float) -> HpipmSettings:
        """Stationarity at `tolerance`, feasibility and complementarity 100x tighter (at least 1e-8): the settings
        the `conic` path has always used."""
        feasibility = max(tolerance / 100, 1e-8)
        return HpipmSettings(tol_stat=tolerance, tol_eq=feasibility, tol_ineq=feasibility, tol_comp=feasibility)

    def but(self, **changes) -> HpipmSettings:
        return dataclasses.replace(self, **changes)


@dataclass
class RtiStep:
    status: int
    iterations: int
    cost: float
    residuals: tuple[float, float, float, float]  # stationarity, equality, inequality, complementarity
    qp_data_s: float  # wall time building the QP (stage functions, HPIPM's structures)
    ipm_s: float  # wall time in HPIPM's interior-point method

    @property
    def ok(self) -> bool:
        return self.status == 0

    @property
    def status_name(self) -> str:
        return HPIPM_STATUS.get(self.status, str(self.status))


@dataclass
class GaussNewtonSteps:
    """The Gauss-Newton steps of one controller tick (HpipmRti.iterate)."""

    last: RtiStep  # the last QP solved
    ok: bool  # the last QP succeeded (status 0, a finite step), so every step was taken
    iterations: int  # interior-point iterations of all the QPs
    wall_s: float  # wall time of all the steps, in C


def _dense(function: ca.Function) -> ca.Function:
    """The same function with every output dense, as the C driver reads them."""
    inputs = [ca.SX.sym(function.name_in(i), function.sparsity_in(i)) for i in range(function.n_in())]
    return ca.Function(function.name(), inputs, [ca.densify(o) for o in function.call(inputs)])


def driver_sources(functions: StageFunctions) -> dict[str, bytes]:
    sources = generated_sources("mpc_rti_model", [_dense(functions.stage), _dense(functions.terminal)], True)
    sources["mpc_rti.c"] = Path(__file__).with_name("rti.c").read_bytes()
    dims = {"NX": NX, "NU": NU, "NP": NP, "YAW_STATE": PSI_INDEX, "YAW_INPUT": PSI_D_INDEX}
    sources["mpc_rti_dims.h"] = "".join(f"#define {k} {v}\n" for k, v in dims.items()).encode()
    return sources


_DOUBLES = ctypes.POINTER(ctypes.c_double)
_INTS = ctypes.POINTER(ctypes.c_int)


def _pointer(array: np.ndarray) -> ctypes.c_void_p:
    return ctypes.c_void_p(array.ctypes.data)


class HpipmRti:
    """One compiled RTI: QP data at the guess w, HPIPM, the step dw. Owns its C object and its buffers."""

    def __init__(
        self,
        library: ctypes.CDLL,
        horizon: int,
        state_bounded: np.ndarray,
        input_bounded: np.ndarray,
        yaw_sp_offset: float,
        settings: HpipmSettings,
    ) -> None:
        self._library = library
        library.mpc_rti_create.restype = ctypes.c_void_p
        library.mpc_rti_create.argtypes = [
            ctypes.c_int, ctypes.c_int, _INTS, ctypes.c_int, _INTS, ctypes.c_double, ctypes.c_int, ctypes.c_int,
            ctypes.c_double, ctypes.c_double, ctypes.c_double, ctypes.c_double, ctypes.c_int, ctypes.c_int,
            ctypes.c_int, ctypes.c_double, ctypes.c_int, ctypes.c_double,
        ]  # fmt: skip
        library.mpc_rti_solve.restype = ctypes.c_int
        library.mpc_rti_solve.argtypes = [ctypes.c_void_p] * 6 + [ctypes.c_double] + [ctypes.c_void_p] * 2
        library.mpc_rti_free.argtypes = [ctypes.c_void_p]
        for function in (library.mpc_rti_iterate, library.mpc_rti_start):
            function.restype = ctypes.c_int
            function.argtypes = [ctypes.c_void_p] * 6 + [ctypes.c_double, ctypes.c_int] + [ctypes.c_void_p] * 2
        library.mpc_rti_wait.restype = ctypes.c_int
        library.mpc_rti_wait.argtypes = [ctypes.c_void_p]
        idxbx = np.flatnonzero(state_bounded).astype(np.intc)
        idxbu = np.flatnonzero(input_bounded).astype(np.intc)
        s = settings
        handle = library.mpc_rti_create(
            horizon, idxbx.size, idxbx.ctypes.data_as(_INTS), idxbu.size, idxbu.ctypes.data_as(_INTS), yaw_sp_offset,
            int(s.mode), s.iter_max, s.tol_stat, s.tol_eq, s.tol_ineq, s.tol_comp, s.warm_start,
            -1 if s.ric_alg is None else s.ric_alg, -1 if s.pred_corr is None else s.pred_corr, s.mu0 or -1.0,
            int(s.residual_exit), s.mu0_warm or -1.0,
        )  # fmt: skip
        if not handle:
            raise MemoryError("mpc_rti_create failed")
        self._handle = ctypes.c_void_p(handle)
        n_w = NX * (horizon + 1) + NU * horizon
        self._w, self._lbw, self._ubw, self.dw = (np.zeros(n_w) for _ in range(4))
        self._params = np.zeros((horizon + 1, NP))  # stage-major: column-major (NP, N+1)
        self._x0 = np.zeros(NX)
        self._info = np.zeros(11)
        self._running = False  # steps handed to the worker thread (start) and not yet waited for (finish)
        self._args = [self._handle] + [_pointer(a) for a in (self._w, self._params, self._x0, self._lbw, self._ubw)]
        self._outputs = [_pointer(self.dw), _pointer(self._info)]

    def __del__(self) -> None:
        handle = self.__dict__.get("_handle")
        if handle:
            self._library.mpc_rti_free(handle)

    def solve(
        self, w: np.ndarray, params: np.ndarray, x0: np.ndarray, lbw: np.ndarray, ubw: np.ndarray, levenberg: float
    ) -> RtiStep:
        """The step of one RTI at the guess w (params (NP, N+1)); the step is in self.dw."""
        self._load(w, params, x0, lbw, ubw)
        status = self._library.mpc_rti_solve(*self._args, levenberg, *self._outputs)
        return self._step(status)

    def iterate(self, w: np.ndarray, params: np.ndarray, x0: np.ndarray, lbw: np.ndarray, ubw: np.ndarray,
                levenberg: float, steps: int) -> GaussNewtonSteps:  # fmt: skip
        """`steps` RTI steps at x0 from the guess w, each taken while they succeed (mpc_rti_iterate); w is moved in
        place."""
        self._load(w, params, x0, lbw, ubw)
        status = self._library.mpc_rti_iterate(*self._args, levenberg, steps, *self._outputs)
        return self._steps(status, w)

    def start(self, w: np.ndarray, params: np.ndarray, x0: np.ndarray, lbw: np.ndarray, ubw: np.ndarray,
              levenberg: float, steps: int) -> None:  # fmt: skip
        """`iterate` on this object's worker thread: returns at once; `finish` waits for it. The arguments are
        copied first, so the caller may change them meanwhile."""
        self._load(w, params, x0, lbw, ubw)  # refuses while a started solve runs
        if self._library.mpc_rti_start(*self._args, levenberg, steps, *self._outputs) != 0:
            raise OSError("cannot start the MPC solver's thread")
        self._running = True

    def finish(self, w: np.ndarray) -> GaussNewtonSteps:
        """Wait for the steps `start` handed on; w becomes the guess they moved."""
        if not self._running:
            raise RuntimeError("no solve was started")
        status = self._library.mpc_rti_wait(self._handle)
        self._running = False
        return self._steps(status, w)

    def _load(self, w: np.ndarray, params: np.ndarray, x0: np.ndarray, lbw: np.ndarray, ubw: np.ndarray) -> None:
        if self._running:
            raise RuntimeError("a solve is running: finish() it first")
        np.copyto(self._w, w)
        np.copyto(self._params, params.T)
        np.copyto(self._x0, x0)
        np.copyto(self._lbw, lbw)
        np.copyto(self._ubw, ubw)

    def _step(self, status: int) -> RtiStep:
        info = self._info
        return RtiStep(status, int(info[1]), float(info[0]), tuple(info[2:6]), float(info[6]), float(info[7]))

    def _steps(self, status: int, w: np.ndarray) -> GaussNewtonSteps:
        np.copyto(w, self._w)
        info = self._info
        return GaussNewtonSteps(self._step(status), bool(info[10]), int(info[8]), float(info[9]))


def build_hpipm_rti(
    functions: StageFunctions,
    horizon: int,
    state_bounded: np.ndarray,
    input_bounded: np.ndarray,
    yaw_sp_offset: float,
    settings: HpipmSettings,
    flags: tuple[str, ...] = COMPILE_FLAGS,
) -> HpipmRti | None:
    """The compiled solver, or None (a notice on stderr from the compiler step) where it cannot be built."""
    path = shared_library("mpc_rti", driver_sources(functions), "vtol-autopilot", flags, LINK_FLAGS)
    if path is None:
        return None
    return HpipmRti(ctypes.CDLL(str(path)), horizon, state_bounded, input_bounded, yaw_sp_offset, settings)
