/* Feature edits: a candidate's features kept together with its poses, its FK and the distance of every point to
 * the reference, changed one feature column over a stretch of frames at a time (motionrep/pipeline/edits.py).
 *
 * An edit adds deltas to one column over consecutive frames and is accepted if every point the column moves stays
 * within the bound in every frame it touches (points it does not move keep their distance). In each frame:
 *
 * - if, for every point it moves, a bound on how far the change can move that point (the column's kind: a
 *   translation moves its points by the change, a rotation vector or Euler angle turns the subtree by at most the
 *   change, a quaternion by at most 2 asin(change / |q|); times the bones' length from the joint down to the
 *   point) plus how far the point already is from the reference (and may have drifted, see below) stays within
 *   the bound, the frame passes without any computation: once the edit is accepted, each point's drift grows by
 *   its bound and the joints are marked to compute later;
 * - else the frame is computed again, only what the column moves: the plan entry that reads it (every entry of
 *   the subtree for a plan of world rotations, whose local rotations depend on their parent's), the FK of the
 *   subtree (its parent's world rotation and position kept), its end sites and their distances, and with them
 *   any joint above still marked from changes let through before;
 * - the frame of the largest change is checked first, where an edit that fails most likely fails, or the frame
 *   the caller names (where the same edit failed in an earlier call; told back for every edit that fails); then
 *   every other frame's room test, and the frames without room are computed, those whose room test went furthest
 *   over the bound first (where the edit most likely fails: an edit that fails is mostly found so in the first
 *   frame computed, not after computing and undoing every frame before it); a failed edit is undone (its frames
 *   computed again from the features as they were: the same inputs, the same bits; the frames let through on
 *   room were not touched).  Which frames come first does not change whether an edit is accepted: a frame passes
 *   on room only where its computation would pass too, so an edit is accepted exactly when every frame it
 *   touches, computed, is within the bound (but for a rounding of the computed distances across the bound within
 *   the room's own margin, never seen).
 *
 * Every frame still marked is computed when the call ends, so the state is then exact again. The arithmetic is
 * the pose plan's (motionrep/model/poseplan.py, through mr_rotconv.h), FK's (fk.c: the same operations in the same
 * order) and max_distances' (fk.c), so the distances kept are those of decoding the current features and running
 * FK on them, bit for bit.  Scalar IEEE float64 only (ccore.h). */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#include "ccore.h"
#include "mr_rotconv.h"

/* the packed plan's header (motionrep/model/poseplan.py: _H_R ... _H_WORLD) */
enum { H_R, H_J, H_P, H_M, H_KINDS, H_COLS, H_AXES, H_JOINTS, H_PARENTS, H_IDENT, H_TCOLS, H_WORLD, H_SIZE };
enum { K_QUAT, K_AXIS_ANGLE, K_EULER, K_EULER_DEGREES, K_ORTHO6D, K_WORLD_QUAT, K_WORLD_IDENTITY };

/* One frame again, in place in the state: the joints js[0..nj) (encoded 2 j + 1 where the joint's plan entry is
 * decoded again, 2 j where only its FK is; increasing j, so a parent is done before its children), then the end
 * sites ss[0..ns), from the features X as they are.  The state keeps each joint's local rotation normalised, as FK
 * uses it.  Returns 0, or 2 for a quaternion of zero length, 3 for a degenerate 6D encoding. */
static int frame_again(const mr_edits *s, int64_t t, const int64_t *js, int64_t nj, const int64_t *ss, int64_t ns)
{
    const int64_t F = s->F, J = s->J, P = s->J + s->E, *pi = s->plan_i;
    const double *X = s->X;
    double *Ln = s->L + t * J * 4, *GP = s->GP + t * J * 4, *G = s->G + t * J * 4, *W = s->W + t * P * 3;
    double *T = s->T + t * s->N * 3, *dist = s->dist + t * P;
    const double *ref = s->ref + t * P * 3;
#define VAL(col) (X[(col) * F + t])
    int status = 0;
    for (int64_t k = 0; k < nj; k++) {
        const int64_t j = js[k] >> 1, p = s->parents[j], r = s->entry[j];
        double *l = Ln + 4 * j;
        if (js[k] & 1) {
            double q[4] = {0.0, 0.0, 0.0, 1.0};
            if (r >= 0) {
                const int64_t kind = pi[pi[H_KINDS] + r], *cols = pi + pi[H_COLS] + 6 * r;
                const int64_t *axes = pi + pi[H_AXES] + 3 * r;
                switch (kind) {
                case K_AXIS_ANGLE:
                    mr_axis_angle(VAL(cols[0]), VAL(cols[1]), VAL(cols[2]), q);
                    break;
                case K_QUAT:
                case K_WORLD_QUAT:
                    if (!mr_normalized(VAL(cols[0]), VAL(cols[1]), VAL(cols[2]), VAL(cols[3]), q))
                        status = 2;
                    break;
                case K_EULER:
                case K_EULER_DEGREES:
                    for (int a = 0; a < 3 && cols[a] >= 0; a++)
                        mr_euler_factor(q, VAL(cols[a]), (int)axes[a], kind == K_EULER_DEGREES);
                    break;
                case K_ORTHO6D:
                    if (!mr_ortho6d(VAL(cols[0]), VAL(cols[1]), VAL(cols[2]), VAL(cols[3]), VAL(cols[4]),
                                    VAL(cols[5]), q))
                        status = 3;
                    break;
                default: /* K_WORLD_IDENTITY: the identity */
                    break;
                }
                if (kind == K_WORLD_QUAT || kind == K_WORLD_IDENTITY) {
                    /* the joint's world rotation r / |r| (or its parent's), made local: conj(G_parent) r */
                    double *gp = GP + 4 * j;
                    const double *g = p < 0 ? NULL : GP + 4 * p;
                    if (kind == K_WORLD_QUAT) {
                        gp[0] = q[0], gp[1] = q[1], gp[2] = q[2], gp[3] = q[3];
                        if (g)
                            mr_product(-g[0], -g[1], -g[2], g[3], q[0], q[1], q[2], q[3], q);
                    } else if (g) {
                        gp[0] = g[0], gp[1] = g[1], gp[2] = g[2], gp[3] = g[3];
                    } else {
                        gp[0] = 0.0, gp[1] = 0.0, gp[2] = 0.0, gp[3] = 1.0;
                    }
                }
            }
            /* normalised as FK does (fk_impl.h) */
            double n = sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
            l[0] = q[0] / n, l[1] = q[1] / n, l[2] = q[2] / n, l[3] = q[3] / n;
        }
        /* the joint's translation slot (the root's, or a translated joint's), from its columns */
        const int64_t slot = s->slot[j];
        double *tr = slot >= 0 ? T + 3 * slot : NULL;
        if (tr)
            for (int a = 0; a < 3; a++) {
                const int64_t col = pi[pi[H_TCOLS] + 3 * slot + a];
                tr[a] = col >= 0 ? VAL(col) : s->plan_f[3 * slot + a];
            }
        /* FK of the joint (fk_impl.h's operations): composed with its parent's */
        const double x = l[0], y = l[1], z = l[2], w = l[3];
        double *g = G + 4 * j, *wj = W + 3 * j;
        if (p < 0) {
            g[0] = x, g[1] = y, g[2] = z, g[3] = w;
            wj[0] = tr[0], wj[1] = tr[1], wj[2] = tr[2];
        } else {
            const double *gp = G + 4 * p, *lt = tr ? tr : s->offsets + 3 * j;
            mr_rotate_add(gp, W + 3 * p, lt[0], lt[1], lt[2], wj);
            double ax = gp[0], ay = gp[1], az = gp[2], aw = gp[3];
            g[0] = aw * x + ax * w + ay * z - az * y;
            g[1] = aw * y - ax * z + ay * w + az * x;
            g[2] = aw * z + ax * y - ay * x + az * w;
            g[3] = aw * w - ax * x - ay * y - az * z;
        }
        const double *b = ref + 3 * j;
        double dx = wj[0] - b[0], dy = wj[1] - b[1], dz = wj[2] - b[2];
        dist[j] = sqrt((dx * dx + dy * dy) + dz * dz); /* max_distances' arithmetic */
    }
#undef VAL
    for (int64_t k = 0; k < ns; k++) {
        const int64_t e = ss[k], p = s->site_parents[e];
        const double *o = s->site_offsets + 3 * e;
        double *we = W + 3 * (J + e);
        mr_rotate_add(G + 4 * p, W + 3 * p, o[0], o[1], o[2], we);
        const double *b = ref + 3 * (J + e);
        double dx = we[0] - b[0], dy = we[1] - b[1], dz = we[2] - b[2];
        dist[J + e] = sqrt((dx * dx + dy * dy) + dz * dz);
    }
    return status;
}

int mr_edits_init(const mr_edits *s)
{
    const int64_t J = s->J, E = s->E;
    int64_t *js = malloc(sizeof(int64_t) * (size_t)(J + E + 1));
    if (!js)
        return -1;
    for (int64_t j = 0; j < J; j++)
        js[j] = 2 * j + 1;
    int64_t *ss = js + J;
    for (int64_t e = 0; e < E; e++)
        ss[e] = e;
    int status = 0;
    for (int64_t t = 0; t < s->F && !status; t++) {
        status = frame_again(s, t, js, J, ss, E);
        for (int64_t pt = 0; pt < J + E && !status; pt++)
            if (!(s->dist[t * (J + E) + pt] <= 1.79769313486231570815e308))
                status = 1;
    }
    free(js);
    return status;
}

/* How far a change of column c at frame t (the column holding `after`, `before` it) can move a point, per unit of
 * the point's factor (lip, ccore.h): from the column's kind, or infinity where there is no bound. */
static double reach(const mr_edits *s, int64_t c, int64_t t, double before, double after)
{
    const int64_t kind = s->lip_kind[c];
    const double change = fabs(after - before);
    if (kind == 1)
        return change;
    if (kind < 2)
        return INFINITY;
    const int64_t *cols = s->plan_i + s->plan_i[H_COLS] + 6 * (kind - 2);
    double q2 = 0.0, p2 = 0.0; /* |q|^2 before and after the change */
    for (int a = 0; a < 4; a++) {
        double v = s->X[cols[a] * s->F + t], u = cols[a] == c ? before : v;
        q2 += u * u;
        p2 += v * v;
    }
    const double x = change / sqrt(q2 < p2 ? q2 : p2);
    /* the two unit quaternions are at most asin(x) apart, their rotations twice that, and asin(x) <= x / sqrt(1 - x^2) */
    return x < 0.5 ? 2.0 * x / sqrt(1.0 - x * x) : INFINITY;
}

/* Frame t exact again for the joints js of the edit at hand (and their end sites) where changes were let through
 * on room alone (mark[j]: bit 1 the joint's entry is to be decoded again, bit 2 its FK computed again): those
 * joints computed again with every marked joint above them (marks cover whole subtrees, so these are the marked
 * part of the path up from each), the end sites below any of them, their marks cleared and their drift 0.  Other
 * marked joints stay as they are, with their drift.  js NULL: every marked joint.  list, sites, in: scratch of J,
 * E and J entries. */
static int frame_marked(const mr_edits *s, int64_t t, uint8_t *mark, double *drift, const int64_t *js, int64_t nj,
                        int64_t *list, int64_t *sites, uint8_t *in)
{
    const int64_t J = s->J, E = s->E;
    uint8_t *mk = mark + t * J;
    if (js) {
        memset(in, 0, (size_t)J);
        for (int64_t k = 0; k < nj; k++) {
            const int64_t j = js[k] >> 1;
            in[j] |= (uint8_t)(1 | ((js[k] & 1) << 1));
            for (int64_t p = s->parents[j]; p >= 0 && mk[p] && !(in[p] & 1); p = s->parents[p])
                in[p] |= 1;
        }
    } else {
        for (int64_t j = 0; j < J; j++)
            in[j] = mk[j] != 0;
    }
    int64_t n = 0, m = 0;
    double *dr = drift + t * (J + E);
    for (int64_t j = 0; j < J; j++)
        if (in[j] & 1) {
            list[n++] = 2 * j + (((in[j] >> 1) | mk[j]) & 1);
            mk[j] = 0;
            dr[j] = 0.0;
        }
    for (int64_t e = 0; e < E; e++)
        if (in[s->site_parents[e]] & 1) {
            sites[m++] = e;
            dr[J + e] = 0.0;
        }
    return frame_again(s, t, list, n, sites, m);
}

enum { PATH_ROOM, PATH_EXACT, PATH_PENDING };
enum { PICKS = 4 }; /* frames without room computed in order of their overshoot, the rest in order */

/* Frame t computed with the features as they are, for the points of the column (joints js, end sites ss): 1 if
 * every one of them is within the bound. */
static int frame_within(const mr_edits *s, int64_t t, uint8_t *mark, double *drift, uint8_t *dirty,
                        const int64_t *js, int64_t nj, const int64_t *ss, int64_t ns, double bound, int64_t *list,
                        uint8_t *in)
{
    const int64_t J = s->J;
    const double *dist = s->dist + t * (J + s->E);
    int ok = dirty[t] ? !frame_marked(s, t, mark, drift, js, nj, list, list + J, in) : !frame_again(s, t, js, nj, ss, ns);
    for (int64_t k = 0; k < nj && ok; k++)
        ok = dist[js[k] >> 1] <= bound;
    for (int64_t k = 0; k < ns && ok; k++)
        ok = dist[J + ss[k]] <= bound;
    return ok;
}

int64_t mr_edits_apply(const mr_edits *s, const int64_t *edits, int64_t m, const double *deltas, double bound,
                       int commit, uint8_t *accepted, int64_t *leads, const int64_t *starts, const double *scales)
{
    const int64_t F = s->F, J = s->J, E = s->E, P = s->J + s->E;
    int64_t longest = 0;
    for (int64_t e = 0; e < m; e++)
        longest = edits[3 * e + 2] > longest ? edits[3 * e + 2] : longest;
    /* per frame of an edit: the feature's value before it, how the frame is checked, how far the change may move
     * a point per unit of its factor, and for the frames to compute, how far over the bound the room test went;
     * per frame and point: drift, a bound on how far the point may be from where the state has it (changes let
     * through on room alone are computed only when a frame must be, or when the call ends), and per joint what is
     * to compute again */
    const size_t L = (size_t)(longest ? longest : 1);
    double *before = malloc(sizeof(double) * L), *drift = calloc((size_t)(F * P + 1), sizeof(double));
    double *moves = malloc(sizeof(double) * L), *over = malloc(sizeof(double) * L);
    uint8_t *path = malloc(L), *mark = calloc((size_t)(F * J + 1), 1), *dirty = calloc((size_t)F + 1, 1);
    uint8_t *in = malloc((size_t)J + 1);
    int64_t *list = malloc(sizeof(int64_t) * (size_t)(J + E + 1)), *pend = malloc(sizeof(int64_t) * L);
    if (!before || !drift || !moves || !over || !path || !mark || !dirty || !in || !list || !pend) {
        free(before), free(drift), free(moves), free(over), free(path), free(mark), free(dirty), free(in), free(list);
        free(pend);
        return -1;
    }
    int64_t count = 0;
    const double *next = deltas;
    for (int64_t e = 0; e < m; e++) {
        const int64_t c = edits[3 * e], first = edits[3 * e + 1], n = edits[3 * e + 2];
        /* the edit's values: d[i], or its scale times its stretch of the shared values (each product formed where
         * its frame is checked) */
        const double *d = starts ? deltas + starts[e] : next, scale = starts ? scales[e] : 1.0;
        if (!starts)
            next += n;
#define DELTA(i) (starts ? d[i] * scale : d[i])
        const int64_t *js = s->cjoints + s->cstart[c], *ss = s->csites + s->sstart[c];
        const int64_t nj = s->cstart[c + 1] - s->cstart[c], ns = s->sstart[c + 1] - s->sstart[c];
        const double *jl = s->lip + s->cstart[c], *sl = s->lip + s->cstart[s->D] + s->sstart[c];
        double *x = s->X + c * F + first;
        int ok = 1;
        /* the frame the caller names first (where the same edit failed before), else the frame of the largest
         * change (where an edit that fails most likely fails): checked first; then every other frame's room test,
         * and the frames without room computed, those whose room test went furthest over the bound first */
        int64_t peak = 0, failed = -1, np = 0, done = 0;
        if (leads && leads[e] >= 0 && leads[e] < n)
            peak = leads[e];
        else
            for (int64_t i = 1; i < n; i++)
                peak = fabs(DELTA(i)) > fabs(DELTA(peak)) ? i : peak;
        for (; done < n && ok; done++) {
            const int64_t i = done == 0 ? peak : done <= peak ? done - 1 : done;
            const int64_t t = first + i;
            const double *dist = s->dist + t * P, *dr = drift + t * P;
            before[i] = x[i];
            x[i] = x[i] + DELTA(i);
            const double move = commit ? reach(s, c, t, before[i], x[i]) : INFINITY;
            /* room enough for every point it moves: as far as the point may be, plus as far as it may move */
            int room = move < INFINITY;
            double worst = INFINITY;
            if (room) {
                worst = -INFINITY;
                for (int64_t k = 0; k < nj; k++) {
                    const double v = dist[js[k] >> 1] + dr[js[k] >> 1] + move * jl[k];
                    worst = v > worst ? v : worst;
                }
                for (int64_t k = 0; k < ns; k++) {
                    const double v = dist[J + ss[k]] + dr[J + ss[k]] + move * sl[k];
                    worst = v > worst ? v : worst;
                }
                room = worst <= bound;
            }
            moves[i] = move;
            if (room) { /* whatever the change does: computed later, if the edit is accepted */
                path[i] = PATH_ROOM;
            } else if (done == 0) {
                path[i] = PATH_EXACT;
                if (!(ok = frame_within(s, t, mark, drift, dirty, js, nj, ss, ns, bound, list, in)))
                    failed = i;
            } else {
                path[i] = PATH_PENDING;
                pend[np] = i;
                over[np++] = worst;
            }
        }
        for (int64_t k = 0; k < np && ok; k++) {
            if (k < PICKS) { /* the furthest over (the first of equals) moved to k, the others kept in order */
                int64_t a = k;
                for (int64_t b = k + 1; b < np; b++)
                    a = over[b] > over[a] ? b : a;
                const int64_t i = pend[a];
                const double v = over[a];
                for (int64_t b = a; b > k; b--)
                    pend[b] = pend[b - 1], over[b] = over[b - 1];
                pend[k] = i, over[k] = v;
            }
            const int64_t i = pend[k];
            path[i] = PATH_EXACT;
            if (!(ok = frame_within(s, first + i, mark, drift, dirty, js, nj, ss, ns, bound, list, in)))
                failed = i;
        }
        if (ok && commit) /* the frames let through on room: their points' drift grows, their joints marked */
            for (int64_t i = 0; i < n; i++)
                if (path[i] == PATH_ROOM) {
                    const int64_t t = first + i;
                    const double move = moves[i];
                    double *dr = drift + t * P;
                    uint8_t *mk = mark + t * J;
                    for (int64_t k = 0; k < nj; k++) {
                        mk[js[k] >> 1] |= (uint8_t)(2 | (js[k] & 1));
                        dr[js[k] >> 1] += move * jl[k];
                    }
                    for (int64_t k = 0; k < ns; k++)
                        dr[J + ss[k]] += move * sl[k];
                    dirty[t] = 1;
                }
        if (!ok || !commit)
            for (int64_t k = 0; k < done; k++) { /* undone: the frames computed with it computed again */
                const int64_t i = k == 0 ? peak : k <= peak ? k - 1 : k;
                x[i] = before[i];
                if (path[i] == PATH_EXACT)
                    frame_again(s, first + i, js, nj, ss, ns);
            }
#undef DELTA
        accepted[e] = (uint8_t)ok;
        if (leads && !ok) /* the frame that failed */
            leads[e] = failed;
        count += ok;
    }
    for (int64_t t = 0; t < F; t++) /* the state exact again */
        if (dirty[t])
            frame_marked(s, t, mark, drift, NULL, 0, list, list + J, in);
    free(before), free(drift), free(moves), free(over), free(path), free(mark), free(dirty), free(in), free(list);
    free(pend);
    return count;
}
