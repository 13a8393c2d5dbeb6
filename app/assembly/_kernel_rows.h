/*
 * The kernels that write CSR rows, for one PetscInt type: _kernel.c includes this file
 * once with T = int32_t, SUFFIX = i32 and once with T = int64_t, SUFFIX = i64.
 */
#define NAME(base) CONCAT(base, SUFFIX)

/*
 * Row pointers (2 (n1 - n0) + 1 each) of the diagonal and the off-diagonal part; -3 when
 * the number of entries does not fit T. The caller then allocates dind, oind to
 * dptr[2 nl], optr[2 nl] entries for NAME(csfem_graph_ind_).
 */
int NAME(csfem_graph_ptr_)(i64 n0, i64 n1, i64 n_nodes, const i64 *quads, const i32 *eptr,
                           const i32 *elist, i32 *work, T *dptr, T *optr)
{
    i64 nl = n1 - n0;
    i64 *buf = neighbour_buffer(nl, eptr, n_nodes, work);
    if (!buf) return -1;
    i64 pd = 0, po = 0;
    dptr[0] = 0;
    optr[0] = 0;
    for (i64 i = 0; i < nl; ++i) {
        i64 n = neighbours(i, quads, eptr, elist, work, buf), nd = 0;
        for (i64 k = 0; k < n; ++k) nd += buf[k] >= n0 && buf[k] < n1;
        dptr[2 * i + 1] = (T)(pd += 2 * nd);
        dptr[2 * i + 2] = (T)(pd += 2 * nd);
        optr[2 * i + 1] = (T)(po += 2 * (n - nd));
        optr[2 * i + 2] = (T)(po += 2 * (n - nd));
        if (pd > T_MAX || po > T_MAX) {
            free(buf);
            return -3;
        }
    }
    free(buf);
    return 0;
}

/* The sorted column indices of both parts (the layout is in _kernel.c's header). */
int NAME(csfem_graph_ind_)(i64 n0, i64 n1, i64 n_nodes, const i64 *quads, const i32 *eptr,
                           const i32 *elist, i32 *work, const T *dptr, const T *optr,
                           T *dind, T *oind)
{
    i64 nl = n1 - n0;
    i64 *buf = neighbour_buffer(nl, eptr, n_nodes, work);
    if (!buf) return -1;
    for (i64 i = 0; i < nl; ++i) {
        i64 n = neighbours(i, quads, eptr, elist, work, buf);
        for (i64 k = 1; k < n; ++k) { /* insertion sort of a dozen nodes */
            i64 c = buf[k], j = k;
            for (; j > 0 && buf[j - 1] > c; --j) buf[j] = buf[j - 1];
            buf[j] = c;
        }
        i64 pd = dptr[2 * i], rd = dptr[2 * i + 1] - pd;
        i64 po = optr[2 * i], ro = optr[2 * i + 1] - po;
        for (i64 k = 0; k < n; ++k) {
            i64 c = buf[k];
            int own = c >= n0 && c < n1;
            T *ind = own ? dind : oind;
            i64 p = own ? pd : po, r = own ? rd : ro;
            T col = (T)(own ? 2 * (c - n0) : 2 * c);
            ind[p] = col; /* row 2i */
            ind[p + 1] = col + 1;
            ind[p + r] = col; /* row 2i + 1 */
            ind[p + r + 1] = col + 1;
            if (own)
                pd += 2;
            else
                po += 2;
        }
    }
    free(buf);
    return 0;
}

/* Add the four 2x2-block entries k[.][a][b] of element nodes q into the rows of q[a]. */
INLINE int NAME(scatter_)(const i64 q[4], const double k[4][4][4], i64 n0, i64 n1,
                          const T *dptr, const T *dind, double *dval, const T *optr,
                          const T *oind, double *oval)
{
    for (int a = 0; a < 4; ++a) {
        if (q[a] < n0 || q[a] >= n1) continue;
        i64 i = q[a] - n0;
        for (int b = 0; b < 4; ++b) {
            i64 c = q[b];
            int own = c >= n0 && c < n1;
            const T *ptr = own ? dptr : optr, *ind = own ? dind : oind;
            double *val = own ? dval : oval;
            T col = (T)(own ? 2 * (c - n0) : 2 * c);
            i64 r0 = ptr[2 * i], r1 = ptr[2 * i + 1], p = r0;
            while (p < r1 && ind[p] != col) p += 2;
            if (p >= r1) return -2;
            i64 p1 = r1 + (p - r0); /* the same column in row 2i + 1 */
            val[p] += k[0][a][b];
            val[p + 1] += k[1][a][b];
            val[p1] += k[2][a][b];
            val[p1 + 1] += k[3][a][b];
        }
    }
    return 0;
}

INLINE int NAME(add_blocks_)(i64 ne, const i64 *quads, const double *points, const i64 *body,
                             const double *dmat, double thickness, int nc, const double *tops,
                             const double *sops, const double *gw, i64 n0, i64 n1,
                             const T *dptr, const T *dind, double *dval, const T *optr,
                             const T *oind, double *oval)
{
    double k[4][4][4];
    for (i64 e = 0; e < ne; ++e) {
        const i64 *q = quads + 4 * e;
        int owned = 0;
        for (int a = 0; a < 4; ++a) owned |= q[a] >= n0 && q[a] < n1;
        if (!owned) continue;
        double x[4], y[4];
        for (int a = 0; a < 4; ++a) {
            x[a] = points[2 * q[a]] - points[2 * q[0]];
            y[a] = points[2 * q[a] + 1] - points[2 * q[0] + 1];
        }
        element_blocks(x, y, nc, tops, sops, gw, dmat + 4 * body[e], thickness, k);
        int status = NAME(scatter_)(q, k, n0, n1, dptr, dind, dval, optr, oind, oval);
        if (status) return status;
    }
    return 0;
}

/*
 * Add the node blocks of every element touching an owned node into the CSR values.
 * tops (nc, 4, 4), sops (nc, 6), gw (nc): the cell operators (see _kernel.c's header);
 * dmat (n_bodies, 4): d11, d12, d22, d33 of every body; body (ne): each element's body.
 * dval, oval hold zeros (or earlier sums) on entry.
 */
int NAME(csfem_add_blocks_)(i64 ne, const i64 *quads, const double *points, const i64 *body,
                            const double *dmat, double thickness, int nc, const double *tops,
                            const double *sops, const double *gw, i64 n0, i64 n1,
                            const T *dptr, const T *dind, double *dval, const T *optr,
                            const T *oind, double *oval)
{
    if (nc < 1 || nc > MAX_CELLS) return -2;
    if (nc == 4) /* a copy with the cell loop unrolled, for 4SD and FEM-Q4 */
        return NAME(add_blocks_)(ne, quads, points, body, dmat, thickness, 4, tops, sops, gw,
                                 n0, n1, dptr, dind, dval, optr, oind, oval);
    return NAME(add_blocks_)(ne, quads, points, body, dmat, thickness, nc, tops, sops, gw, n0,
                             n1, dptr, dind, dval, optr, oind, oval);
}

#undef NAME
