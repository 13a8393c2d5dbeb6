/*
 * Compiled stiffness assembly: the node graph of a rank's rows and the element node
 * blocks added straight into CSR values. Plain C on raw buffers, called through ctypes
 * from app/assembly/compiled.py (no numpy C API, so no numpy ABI dependency).
 *
 * Conventions (the same as app/assembly/stiffness.py):
 * - quads: (ne, 4) int64 node indices, counter-clockwise; points: (n_nodes, 2) float64.
 * - The rank owns nodes [n0, n1) and so the DOF rows 2*node + component.
 * - Rows are split the way MatCreateMPIAIJWithSplitArrays takes them: the "diagonal"
 *   part holds the columns of owned nodes as local DOF indices 2*(node - n0) + c, the
 *   "off-diagonal" part the columns of other ranks' nodes as global DOF indices
 *   2*node + c. Columns are sorted in each row. On one rank the off-diagonal part is
 *   empty and the diagonal part is the whole matrix.
 * - Node I's neighbours are the nodes that share an element with it (I included); rows
 *   2I and 2I+1 hold the same columns: (2c, 2c+1) for every neighbour c.
 *
 * Element matrices. Every cell c of an element (a CS-FEM smoothing cell or a FEM-Q4
 * Gauss point) is described by constant 4x4 operators on the element's node
 * coordinates x, y (4 each), built in compiled.py from the same tables as
 * app/discretisation/elements.py:
 *   measure  m_c = x^T S_c y           (cell area, or det J at a Gauss point),
 *   gradient bx_c = (T_c y) / m_c,  by_c = -(T_c x) / m_c,
 *   weight   w_c = g_c m_c             (g_c = 1, or the Gauss weight).
 * S_c is antisymmetric and given by its upper triangle (S01, S02, S03, S12, S13, S23).
 * Coordinates are taken relative to the element's first node: gradients and measures do
 * not change under a translation, and the digits that absolute coordinates far from the
 * origin would cost in the differences of nearby corners are kept. The node blocks are
 * then
 *   K_uu = d11 xx + d33 yy,  K_uv = d12 xy + d33 xy^T,  K_vu = K_uv^T,
 *   K_vv = d22 yy + d33 xx,  with xx = t sum_c w_c bx_c bx_c^T, yy likewise and
 *   xy = t sum_c w_c bx_c by_c^T.
 *
 * Return codes: 0 on success, -1 when memory runs out, -2 on bad input, -3 when the
 * matrix has too many entries for the index type.
 */
#define PY_SSIZE_T_CLEAN
#include <Python.h>

#include <stdint.h>
#include <stdlib.h>
#include <string.h>

typedef int64_t i64;
typedef int32_t i32;

#define INLINE static inline __attribute__((always_inline))
#define MAX_CELLS 16

/* ------------------------------------------------------------------ node incidence */

/*
 * Incidences are counted in 32 bits: the caller makes sure that 4 ne < 2^31. work is a
 * scratch array of n_nodes int32 that the graph functions share.
 */

/* eptr (n1 - n0 + 1): offsets of every owned node's element list; returns the total. */
i64 csfem_incidence_count(i64 ne, const i64 *quads, i64 n0, i64 n1, i32 *eptr)
{
    i64 nl = n1 - n0;
    memset(eptr, 0, (size_t)(nl + 1) * sizeof(i32));
    for (i64 k = 0; k < 4 * ne; ++k) {
        i64 a = quads[k];
        if (a >= n0 && a < n1) ++eptr[a - n0 + 1];
    }
    for (i64 i = 0; i < nl; ++i) eptr[i + 1] += eptr[i];
    return eptr[nl];
}

/* elist (eptr[n1 - n0]): the elements of every owned node, ascending. */
void csfem_incidence_fill(i64 ne, const i64 *quads, i64 n0, i64 n1, const i32 *eptr,
                          i32 *elist, i32 *work)
{
    i32 *cursor = work;
    memcpy(cursor, eptr, (size_t)(n1 - n0) * sizeof(i32));
    for (i64 e = 0; e < ne; ++e) {
        for (int k = 0; k < 4; ++k) {
            i64 a = quads[4 * e + k];
            if (a >= n0 && a < n1) elist[cursor[a - n0]++] = (i32)e;
        }
    }
}

/* ------------------------------------------------------------------ node graph */

/*
 * The neighbours of owned node i (unsorted, each once) into buf; returns how many.
 * mark (n_nodes) holds a stamp per node: node c is already in buf when mark[c] == i.
 */
INLINE i64 neighbours(i64 i, const i64 *quads, const i32 *eptr, const i32 *elist, i32 *mark,
                      i64 *buf)
{
    i64 n = 0;
    for (i64 k = eptr[i]; k < eptr[i + 1]; ++k) {
        const i64 *q = quads + 4 * (i64)elist[k];
        for (int m = 0; m < 4; ++m) {
            i64 c = q[m];
            if (mark[c] != (i32)i) {
                mark[c] = (i32)i;
                buf[n++] = c;
            }
        }
    }
    return n;
}

/* A buffer for the neighbours of any owned node, and the marks reset to -1. */
static i64 *neighbour_buffer(i64 nl, const i32 *eptr, i64 n_nodes, i32 *mark)
{
    i64 m = 0;
    for (i64 i = 0; i < nl; ++i)
        if (eptr[i + 1] - eptr[i] > m) m = eptr[i + 1] - eptr[i];
    memset(mark, 0xff, (size_t)n_nodes * sizeof(i32));
    return malloc((size_t)(4 * m + 1) * sizeof(i64));
}

/* ------------------------------------------------------------------ element kernel */

/* The four node blocks k[0..3] = K_uu, K_uv, K_vu, K_vv (each [a][b]) of one element. */
INLINE void element_blocks(const double x[4], const double y[4], int nc, const double *tops,
                           const double *sops, const double *gw, const double *d,
                           double thickness, double k[4][4][4])
{
    /* cross products x_a y_b - x_b y_a of the pairs 12, 13, 23 (x_0 = y_0 = 0) */
    double c12 = x[1] * y[2] - x[2] * y[1];
    double c13 = x[1] * y[3] - x[3] * y[1];
    double c23 = x[2] * y[3] - x[3] * y[2];
    /* u = T_c y, v = T_c x and f = t g_c / m_c of every cell, cells last */
    double u[4][MAX_CELLS], v[4][MAX_CELLS], fu[4][MAX_CELLS], fv[4][MAX_CELLS];
    for (int c = 0; c < nc; ++c) {
        const double *t = tops + 16 * c, *s = sops + 6 * c;
        double m = s[3] * c12 + s[4] * c13 + s[5] * c23;
        double f = gw[c] * thickness / m;
        for (int a = 0; a < 4; ++a) {
            u[a][c] = t[4 * a + 1] * y[1] + t[4 * a + 2] * y[2] + t[4 * a + 3] * y[3];
            v[a][c] = t[4 * a + 1] * x[1] + t[4 * a + 2] * x[2] + t[4 * a + 3] * x[3];
            fu[a][c] = f * u[a][c];
            fv[a][c] = f * v[a][c];
        }
    }
    /* xx = sum_c f u u^T (symmetric), yy = sum_c f v v^T, xy = -sum_c f u v^T */
    double xx[4][4], yy[4][4], xy[4][4];
    for (int a = 0; a < 4; ++a) {
        for (int b = a; b < 4; ++b) {
            double sx = 0.0, sy = 0.0;
            for (int c = 0; c < nc; ++c) {
                sx += fu[a][c] * u[b][c];
                sy += fv[a][c] * v[b][c];
            }
            xx[a][b] = sx;
            yy[a][b] = sy;
        }
        for (int b = 0; b < 4; ++b) {
            double s = 0.0;
            for (int c = 0; c < nc; ++c) s -= fu[a][c] * v[b][c];
            xy[a][b] = s;
        }
    }
    double d11 = d[0], d12 = d[1], d22 = d[2], d33 = d[3];
    for (int a = 0; a < 4; ++a) {
        for (int b = a; b < 4; ++b) {
            k[0][a][b] = k[0][b][a] = d11 * xx[a][b] + d33 * yy[a][b];
            k[3][a][b] = k[3][b][a] = d22 * yy[a][b] + d33 * xx[a][b];
        }
        for (int b = 0; b < 4; ++b) k[1][a][b] = k[2][b][a] = d12 * xy[a][b] + d33 * xy[b][a];
    }
}

/* ------------------------------------------------------------------ CSR rows */

#define CONCAT_(a, b) a##b
#define CONCAT(a, b) CONCAT_(a, b)

#define T int32_t
#define T_MAX INT32_MAX
#define SUFFIX i32
#include "_kernel_rows.h"
#undef T
#undef T_MAX
#undef SUFFIX

#define T int64_t
#define T_MAX INT64_MAX
#define SUFFIX i64
#include "_kernel_rows.h"
#undef T
#undef T_MAX
#undef SUFFIX

/* ------------------------------------------------------------------ module */

/* An importable module with no Python functions, so that the shared library is found
   like any other module of the package (its kernels are reached through ctypes). */
static struct PyModuleDef kernel_module = {
    PyModuleDef_HEAD_INIT, "_kernel",
    "Compiled assembly kernels; see app/assembly/compiled.py.", -1, NULL,
    NULL, NULL, NULL, NULL};

PyMODINIT_FUNC PyInit__kernel(void) { return PyModule_Create(&kernel_module); }
