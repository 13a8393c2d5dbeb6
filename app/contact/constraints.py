"""What a contact discretisation hands to the rest of the contact stage.

A discretisation (node-to-segment, mortar, see `app.contact.discretisation`) turns an
interface into m multipliers (one per slave node) and their constraint rows. Everything
after it (condensation C = G K^-1 G^T, the modified Coulomb LCP, load steps, debonding,
floating bodies, output and the KKT check) only sees a `ContactConstraints`.

Sign conventions are those of `app.contact.pairs`: normal rows give the opening
(positive = separation, length), tangential rows the slip of the slave along the tangent
t = (-n_y, n_x) (length); the multipliers are forces (force per thickness x thickness).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp

from app.contact.pairs import XI_EPS, ContactPairs
from app.errors import InputError


@dataclass
class ContactConstraints:
    """Constraint rows of m multipliers, stored row by row with a fixed width k.

    pairs: per multiplier data (`ContactPairs`): interface index, slave node, position
        (output point), normal and tangent, initial gap g0 (length) and weight `length`
        (tributary length; force / (length x thickness) = traction). `master` and `xi`
        name the master segment and parameter closest to the slave node (for output).
    cols: (m, k) int64 DOF columns (2 node + component) of each row; padding has weight 0.
    g_normal, g_tangent: (m, k) weights: opening_j = g0_j + sum_c g_normal[j, c] u[cols[j, c]]
        and slip_j = sum_c g_tangent[j, c] u[cols[j, c]].
    master_interpolation: how the rows interpolate the master side ("linear": its own
        piecewise-linear trace; app/contact/mortar_smooth.py: "quadratic B-spline"); a
        concatenation of several interfaces says "mixed" when they differ.
    """

    pairs: ContactPairs
    cols: np.ndarray
    g_normal: np.ndarray
    g_tangent: np.ndarray
    master_interpolation: str = "linear"

    @property
    def n_pairs(self) -> int:
        return self.pairs.n_pairs

    @classmethod
    def empty(cls) -> ContactConstraints:
        """No pairs and no rows (shapes (0, 1))."""
        z = np.zeros((0, 1))
        return cls(ContactPairs.empty(), np.zeros((0, 1), dtype=np.int64), z, z.copy())

    @classmethod
    def concatenate(cls, parts: Sequence[ContactConstraints]) -> ContactConstraints:
        """Stack several constraint sets (one per interface) in order, padding the rows."""
        parts = list(parts)
        if not parts:
            return cls.empty()
        k = max(p.cols.shape[1] for p in parts)

        def pad(a: np.ndarray) -> np.ndarray:
            return np.pad(a, ((0, 0), (0, k - a.shape[1])))

        kinds = {p.master_interpolation for p in parts}
        return cls(ContactPairs.concatenate([p.pairs for p in parts]),
                   np.concatenate([pad(p.cols) for p in parts]),
                   np.concatenate([pad(p.g_normal) for p in parts]),
                   np.concatenate([pad(p.g_tangent) for p in parts]),
                   kinds.pop() if len(kinds) == 1 else "mixed")

    def matrix(self, n_nodes: int) -> sp.csr_matrix:
        """G, shape (2m, 2 n_nodes): rows 0..m-1 normal, m..2m-1 tangential."""
        m, k = self.cols.shape
        if m and self.cols.max() >= 2 * n_nodes:
            raise InputError(f"constraint rows refer to nodes beyond n_nodes={n_nodes}")
        rows = np.repeat(np.arange(2 * m), k)
        g = sp.csr_matrix((np.concatenate([self.g_normal, self.g_tangent]).ravel(),
                           (rows, np.concatenate([self.cols, self.cols]).ravel())),
                          shape=(2 * m, 2 * n_nodes))
        g.eliminate_zeros()
        return g

    def one_pair_per_node(self, points: np.ndarray,
                          tributary: np.ndarray | None = None) -> ContactConstraints:
        """These rows with a slave node paired in two interfaces once beyond a free end of
        one master (its end pair: the node projects past the end segment by more than
        XI_EPS, `app.contact.pairs.end_overlaps`) and once inside another (two masters
        meeting end to end, a slave corner just past their joint) kept once: the deepest
        of its pairs (smallest g0; the inside one unless an end pair is deeper by more
        than 1e-9 of the node's lengths), its length the summed lengths of its pairs as
        deep as that one (within the same 1e-9: the node's covered length where the
        masters meet end to end), at most the node's tributary length. points (n, 2)
        mesh coordinates; tributary (n,) the slave nodes' tributary lengths (None: no
        cap). Keeping the inside pair always (reviewer `review18`) dropped a corner's
        overlap of 0.002 at a block's top end for an open pair on the block's side (gap
        0.02) or on a block stepped down, and gave it 0.08 + 0.1 on the side. Other
        nodes paired twice are left for the caller to refuse."""
        pr = self.pairs
        if pr.n_pairs == 0:
            return self
        xa, xb = points[pr.master[:, 0]], points[pr.master[:, 1]]
        ab = xb - xa
        xr = np.einsum("ij,ij->i", pr.position - xa, ab) / np.einsum("ij,ij->i", ab, ab)
        end = (xr < -XI_EPS) | (xr > 1.0 + XI_EPS)
        _, inv, counts = np.unique(pr.slave, return_inverse=True, return_counts=True)
        inside = np.bincount(inv, weights=~end, minlength=counts.size)[inv]
        shared = (counts[inv] > 1) & (inside == 1)
        if not shared.any():
            return self
        n = counts.size
        total = np.bincount(inv, weights=np.where(shared, pr.length, 0.0), minlength=n)
        g_in = np.full(n, np.inf)
        np.minimum.at(g_in, inv[shared & ~end], pr.g0[shared & ~end])
        g_end = np.full(n, np.inf)
        np.minimum.at(g_end, inv[shared & end], pr.g0[shared & end])
        deeper_end = g_end < g_in - 1e-9 * total  # else the inside pair
        # one kept per node: its inside pair, or its deepest end pair (the first of ties)
        idx = np.arange(pr.n_pairs)
        kept_at = np.full(n, -1)
        kept_at[inv[shared & ~end]] = idx[shared & ~end]
        ends = idx[shared & end][np.lexsort((pr.g0[shared & end], inv[shared & end]))]
        _, first = np.unique(inv[ends], return_index=True)
        kept_at[inv[ends[first]]] = np.where(deeper_end[inv[ends[first]]], ends[first],
                                             kept_at[inv[ends[first]]])
        keep = ~shared | (idx == kept_at[inv])
        # the lengths of the node's pairs as deep as the kept one (masters end to end)
        g_kept = np.where(deeper_end, g_end, g_in)
        level = shared & (pr.g0 <= g_kept[inv] + 1e-9 * total[inv])
        length = np.where(shared, np.bincount(inv, weights=np.where(level, pr.length, 0.0),
                                              minlength=n)[inv], pr.length)
        if tributary is not None:
            length = np.where(shared, np.minimum(length, tributary[pr.slave]), length)
        pairs = pr.select(keep)
        pairs.length = length[keep]
        return ContactConstraints(pairs, self.cols[keep], self.g_normal[keep],
                                  self.g_tangent[keep], self.master_interpolation)
