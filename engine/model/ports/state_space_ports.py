"""A state space x' = A x + B u, y = C x + D u with m inputs and m outputs as one block of a
block diagram: each input port reads a signal, each output port produces one.

One block, one set of states.  A diagram's network is a graph of single-input single-output
entries (`engine.model.network`); the block enters it as its m x m channels, the entry from
input j to output i being C_i (sI - A)^-1 B_j + D_ij (`StateSpaceChannel`: a SISO state space
kept as state space, evaluated as any other), and every channel names the block it belongs
to.  The network's realization (`engine.loop.realization`) places the block's states once:
its B columns at the signals its inputs read, its C rows at the signals its outputs produce,
D in the feedthrough; so the loop seen at any break is formed exactly as for SISO blocks, and
no mode is copied (m^2 copies would be hidden modes of every closed loop).

Coordinates.  The block is balanced once as a whole (LAPACK's gebal on [[A, B], [C, 0]],
powers of two on the states alone, exact), as a SISO block is
(`engine.model.state_space.balanced`): nothing formed from it depends on the coordinates
given.  A block in z is brought to its w-plane form as a whole (`in_w`)."""

from __future__ import annotations

from collections.abc import Mapping
from functools import cached_property

import numpy as np
from numpy.typing import ArrayLike, NDArray

from engine.errors import BlockError
from engine.model.bilinear import realization_in_w
from engine.model.blocks import Compiled, StateSpaceTransfer
from engine.model.expressions import Dual
from engine.model.state_space import MAX_STATES, MODAL_CONDITION, WORK_ELEMENTS, real_matrix, shape_text, state_scales

MAX_PORTS = 8  # inputs (and outputs) of a block, loops of a plant (mu is searched over m - 1 scalings)

Matrices4 = tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]


def checked_ports(A: ArrayLike, B: ArrayLike, C: ArrayLike, D: ArrayLike, where: str) -> Matrices4:
    """A (n x n), B (n x m), C (m x n) and D (m x m; a number 0: no feedthrough) of a square state
    space (a block of several ports, `analyze --ss`'s plant), or a `BlockError` naming ``where`` and
    what is wrong.  No states: A [] and B, C empty, D m x m (a static plant)."""
    a, b, c, d = (real_matrix(x, name, where) for x, name in ((A, "A"), (B, "B"), (C, "C"), (D, "D")))
    if a.size == 0 and d.ndim == 2:  # no states: a static plant D ([] read as 0 x 0, B 0 x m, C m x 0)
        a, b, c = np.zeros((0, 0)), np.zeros((0, d.shape[1])), np.zeros((d.shape[0], 0))
    n = a.shape[0] if a.ndim == 2 else -1
    if a.ndim != 2 or a.shape[1] != n:
        raise BlockError(f"{where}: A must be a square matrix, not {shape_text(a)}")
    if n > MAX_STATES:
        raise BlockError(f"{where}: order {n} is beyond the limit of {MAX_STATES} states")
    if b.ndim != 2 or c.ndim != 2 or b.shape[0] != n or c.shape[1] != n:
        raise BlockError(
            f"{where}: B must be {n} x m and C m x {n} (A is {n} x {n}, m inputs and outputs), "
            f"not {shape_text(b)} and {shape_text(c)}"
        )
    m, outputs = b.shape[1], c.shape[0]
    if m != outputs:
        raise BlockError(
            f"{where}: {m} inputs and {outputs} outputs: not square (m loops need as many outputs as inputs)"
        )
    if not 1 <= m <= MAX_PORTS:
        raise BlockError(f"{where}: {m} inputs and outputs; the limit is 1 to {MAX_PORTS}")
    d = np.zeros((m, m)) if d.size == 1 and not d.any() else d
    if d.shape != (m, m):
        raise BlockError(f"{where}: D is {shape_text(d)}; it must be {m} x {m}")
    return a, b, c, d


class PortedStateSpace:
    """A checked square state space of m ports (``given``: as it came; ``A``, ``B``, ``C``, ``D``:
    balanced) and its channels (module docstring)."""

    def __init__(self, A: ArrayLike, B: ArrayLike, C: ArrayLike, D: ArrayLike = 0.0, source: str = "state space"):
        self.given = checked_ports(A, B, C, D, source)
        self.source = source
        self.A, self.B, self.C, self.D = balanced_ports(*self.given)
        self._kept: tuple[NDArray, tuple[NDArray, NDArray]] | None = None  # last points, `shared_response`
        self.channels = tuple(
            tuple(StateSpaceChannel(self, i, j) for j in range(self.ports)) for i in range(self.ports)
        )

    @property
    def ports(self) -> int:
        return int(self.D.shape[0])

    @property
    def order(self) -> int:
        return int(self.A.shape[0])

    def channel_is_zero(self, output_port: int, input_port: int) -> bool:
        """Is the channel 0 at every frequency by the block's structure: D_ij = 0 and every Markov
        parameter C_i A^k B_j (k < n) exactly 0 (zeros that balancing keeps; an overflow is not 0)?"""
        if self.D[output_port, input_port] != 0:
            return False
        c, v = self.C[output_port], self.B[:, input_port]
        with np.errstate(all="ignore"):
            for _ in range(self.order):
                if c @ v != 0:
                    return False
                v = self.A @ v
        return True

    @cached_property
    def poles(self) -> NDArray[np.complex128]:
        """The eigenvalues of A: the block's modes, each once."""
        return np.linalg.eigvals(self.A).astype(complex) if self.order else np.zeros(0, dtype=complex)

    @cached_property
    def modal(self) -> tuple[NDArray[np.complex128], NDArray[np.complex128]] | None:
        """(poles, residues r[k, i, j] = (C V)[i, k] (V^-1 B)[k, j]) when A's eigenvectors are well
        conditioned (`MODAL_CONDITION`, as a SISO block's modal sum), else None."""
        if not self.order:
            return None
        with np.errstate(all="ignore"):
            poles, vectors = np.linalg.eig(self.A)
            if not (np.all(np.isfinite(vectors)) and np.linalg.cond(vectors) <= MODAL_CONDITION):
                return None
            into = np.linalg.solve(vectors, self.B.astype(complex))
            residues = (self.C @ vectors).T[:, :, None] * into[:, None, :]
        return (poles, residues) if np.all(np.isfinite(residues)) else None

    def shared_response(self, s: NDArray[np.complex128]) -> tuple[NDArray, NDArray] | None:
        """Every channel's value and slope at the points ``s`` (flat; arrays points x m x m) by the modal
        sum, kept for the next channel asked at the same points (a network evaluates every channel at one
        array of points); None when the block is not modal or the batch is large (each channel's own
        evaluation then: `StateSpaceTransfer`)."""
        if self.modal is None or s.size * self.order > WORK_ELEMENTS:
            return None
        kept = self._kept
        if kept is not None and kept[0].shape == s.shape and np.array_equal(kept[0], s):
            return kept[1]
        poles, residues = self.modal
        flat = residues.reshape(self.order, -1)
        with np.errstate(all="ignore"):  # a pole hit exactly: not finite, reported by the caller
            inverse = 1.0 / (s[:, None] - poles[None, :])
            values = (inverse @ flat).reshape(s.size, self.ports, self.ports) + self.D[None, :, :]
            slopes = -((inverse * inverse) @ flat).reshape(s.size, self.ports, self.ports)
        self._kept = (s.copy(), (values, slopes))  # one tuple: a thread reading it sees the pair whole
        return values, slopes

    @cached_property
    def in_w(self) -> PortedStateSpace:
        """The block in z as its w-plane form, z = (1 + w)/(1 - w) (`realization_in_w`), made once."""
        try:
            return PortedStateSpace(*realization_in_w(self.A, self.B, self.C, self.D), source=f"{self.source}, in z")
        except BlockError as exc:
            raise BlockError(f"{self.source}: {exc}") from None


def balanced_ports(a: NDArray, b: NDArray, c: NDArray, d: NDArray) -> Matrices4:
    """The same block with its states scaled by powers of two (module docstring)."""
    if a.shape[0] == 0:
        return a, b, c, d
    t = state_scales(a, b, c)
    return a * t[None, :] / t[:, None], b / t[:, None], c * t[None, :], d


class StateSpaceChannel(StateSpaceTransfer):
    """The channel of ``block`` from input ``input_port`` to output ``output_port`` (from 0): a SISO
    state space of the block's balanced states, whose entry in a network the realization places
    among the block's others (module docstring)."""

    def __init__(self, block: PortedStateSpace, output_port: int, input_port: int) -> None:
        i, j = output_port, input_port
        where = f"{block.source}, output {i + 1} from input {j + 1}"
        super().__init__(block.A, block.B[:, j], block.C[i], block.D[i, j], where)
        self.block, self.output_port, self.input_port = block, i, j

    def __call__(self, s: ArrayLike) -> tuple[NDArray[np.complex128], NDArray[np.complex128]]:
        """The channel's value and slope at ``s``: from the block's modal sum shared by its channels
        (`PortedStateSpace.shared_response`), else from its own decomposition."""
        s = np.asarray(s, dtype=complex)
        shared = self.block.shared_response(s.ravel())
        if shared is None:
            return self.response(s)
        i, j = self.output_port, self.input_port
        return shared[0][:, i, j].reshape(s.shape), shared[1][:, i, j].reshape(s.shape)

    def compile(self, params: Mapping[str, float]) -> Compiled:
        return self

    def evaluate(
        self, x: NDArray, params: Mapping[str, float], with_dvar: bool = False, with_grad: bool = True
    ) -> Dual:
        value, slope = self(x)
        return Dual(value, {}, slope if with_dvar else None)

    def in_w(self) -> StateSpaceChannel:
        """The same channel of the block's w-plane form (`PortedStateSpace.in_w`)."""
        return self.block.in_w.channels[self.output_port][self.input_port]
