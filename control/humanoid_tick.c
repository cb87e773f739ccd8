/* The humanoid stabilizer's tick (skatelib.control.humanoid_stabilizer.LipStabilizer) after its
 * kinematics: the estimate from the sensors, the COM offset observer, the DCM feedback and its
 * desired ZMP held in the support polygon, the COM command, the ankles' damping control, the swing
 * soles' height control and the joint correction's solve, in C: the same equations in the same
 * order; the Python module documents them. Pinocchio computes the kinematics it reads (the
 * measured configuration's COM, soles and ankle sensors; the planned configuration's Jacobians).
 * Built by skatelib.control.humanoid_native with the system's C compiler and called by ctypes.
 * Matrices are row-major; two soles' (2, 3) rows are stored as 6 doubles, right then left. */
#include <math.h>
#include <string.h>

#define MAX_NV 64

typedef struct {
    double dt, dcm_gain, velocity_cutoff_hz, offset_rate, polygon_margin, ankle_damping, ankle_return;
    double ankle_tilt_max, com_shift_max, lip, com_velocity_gain, swing_height_gain, swing_return, enabled;
    double min_load, toe_off;
    int nv;
} hs_params;

/* inputs: the reference sample (after the landing detection), the measured kinematics, the ankle
 * sensors, the planned configuration's soles' rotations, the soles' size (length, width) and the
 * correction's rows (nv x nv) */
enum { I_SOLES = 0, I_YAW = 6, I_SUPPORT = 8, I_ANCHORS = 10, I_SOLEVEL = 12, I_COM = 18, I_COMV = 21,
       I_ZMP = 24, I_GRAVITY = 26, I_GROUND = 27, I_PITCH = 28, I_C = 30, I_MSOLES = 33, I_PTS = 39,
       I_ROTS = 45, I_FORCE = 63, I_TORQUE = 69, I_RSOLE = 75, I_SIZE = 93, I_A = 95 };
/* state, kept between ticks */
enum { S_DC = 0, S_DV = 2, S_ACC = 4, S_OFFSET = 6, S_TILT = 8, S_LIFT = 12, S_SWINGZ = 14, S_RELPREV = 16,
       S_HASPREV = 19, S_SUPPREV = 20, S_V = 22, S_VWORLD = 25, S_N = 28 };
/* outputs */
enum { O_COM = 0, O_XI = 3, O_ZMP = 5, O_PD = 7, O_DC = 9, O_SINGULAR = 11, O_DQ = 12 };

static double clip(double x, double lo, double hi) { return x < lo ? lo : (x > hi ? hi : x); }

/* the mean of the rows (3) of the soles flagged in on (one or two; none: zeros, which the caller
 * does not let happen: the Python side refuses a tick without an anchor sole) */
static void mean_rows(const double *rows, const double *on, double *o) {
    if (on[0] != 0.0 && on[1] != 0.0) {
        for (int i = 0; i < 3; i++) o[i] = (rows[i] + rows[3 + i]) / 2;
    } else {
        const double *r = on[0] != 0.0 ? rows : (on[1] != 0.0 ? rows + 3 : NULL);
        for (int i = 0; i < 3; i++) o[i] = r ? r[i] : 0.0;
    }
}

static double cross2(const double *o, const double *a, const double *b) {
    return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0]);
}

static int lex_less(const double *a, const double *b) { return a[0] < b[0] || (a[0] == b[0] && a[1] < b[1]); }

/* the support soles' convex hull, each sole shrunk by margin (counter-clockwise, as the
 * reference's polygon: the corners rounded to 1e-12, duplicates dropped, the monotone chain);
 * its number of vertices */
static int polygon(const double *in, double margin, double hull[][2]) {
    static const double corner[4][2] = {{1.0, 1.0}, {-1.0, 1.0}, {-1.0, -1.0}, {1.0, -1.0}};
    double pts[8][2], half[2] = {in[I_SIZE] / 2 - margin, in[I_SIZE + 1] / 2 - margin};
    int n = 0;
    for (int s = 0; s < 2; s++) {
        if (in[I_SUPPORT + s] == 0.0) continue;
        double c = cos(in[I_YAW + s]), sn = sin(in[I_YAW + s]);
        for (int k = 0; k < 4; k++) {
            double dx = corner[k][0] * half[0], dy = corner[k][1] * half[1];
            double x = in[I_SOLES + 3 * s] + (c * dx - sn * dy), y = in[I_SOLES + 3 * s + 1] + (sn * dx + c * dy);
            double q[2] = {rint(x * 1e12) / 1e12, rint(y * 1e12) / 1e12};
            int at = n, dup = 0;  /* insertion into the sorted, unique points */
            for (int i = 0; i < n; i++) {
                if (pts[i][0] == q[0] && pts[i][1] == q[1]) { dup = 1; break; }
                if (lex_less(q, pts[i])) { at = i; break; }
            }
            if (dup) continue;
            memmove(pts[at + 1], pts[at], sizeof(pts[0]) * (size_t)(n - at));
            pts[at][0] = q[0], pts[at][1] = q[1];
            n++;
        }
    }
    double lower[16][2], upper[16][2];
    int nl = 0, nu = 0;
    for (int i = 0; i < n; i++) {
        while (nl >= 2 && cross2(lower[nl - 2], lower[nl - 1], pts[i]) <= 0) nl--;
        lower[nl][0] = pts[i][0], lower[nl][1] = pts[i][1], nl++;
    }
    for (int i = n - 1; i >= 0; i--) {
        while (nu >= 2 && cross2(upper[nu - 2], upper[nu - 1], pts[i]) <= 0) nu--;
        upper[nu][0] = pts[i][0], upper[nu][1] = pts[i][1], nu++;
    }
    int m = 0;
    for (int i = 0; i < nl - 1; i++) hull[m][0] = lower[i][0], hull[m][1] = lower[i][1], m++;
    for (int i = 0; i < nu - 1; i++) hull[m][0] = upper[i][0], hull[m][1] = upper[i][1], m++;
    return m;
}

/* the reference's polygon_margin: the distance of q inside the polygon (negative: outside) */
static double polygon_margin(double hull[][2], int m, const double *q) {
    double best = INFINITY;
    for (int i = 0; i < m; i++) {
        const double *a = hull[i], *b = hull[(i + 1) % m];
        double e0 = b[0] - a[0], e1 = b[1] - a[1];
        double d = (e0 * (q[1] - a[1]) - e1 * (q[0] - a[0])) / sqrt(e0 * e0 + e1 * e1);
        if (d < best) best = d;
    }
    return best;
}

/* the reference's clamp: q held inside the support polygon less margin (the nearest point of it) */
static void clamp(const hs_params *p, const double *in, double *q) {
    double hull[16][2];
    int m = polygon(in, p->polygon_margin, hull);
    if (polygon_margin(hull, m, q) >= 0.0) return;
    double best[2] = {q[0], q[1]}, dist = INFINITY;
    for (int i = 0; i < m; i++) {
        const double *a = hull[i], *b = hull[(i + 1) % m];
        double ba[2] = {b[0] - a[0], b[1] - a[1]}, qa[2] = {q[0] - a[0], q[1] - a[1]};
        double bb = ba[0] * ba[0] + ba[1] * ba[1];
        double t = clip((qa[0] * ba[0] + qa[1] * ba[1]) / (bb > 1e-12 ? bb : 1e-12), 0.0, 1.0);
        double x[2] = {a[0] + t * ba[0], a[1] + t * ba[1]}, r[2] = {q[0] - x[0], q[1] - x[1]};
        double n = sqrt(r[0] * r[0] + r[1] * r[1]);
        if (n < dist) best[0] = x[0], best[1] = x[1], dist = n;
    }
    q[0] = best[0], q[1] = best[1];
}

/* the reference's foot_cop: the desired centre of pressure on sole s (its frame: x, y) */
static void foot_cop(const double *in, int s, const double *pd, double *o) {
    double d[2];
    if (in[I_SUPPORT] != 0.0 && in[I_SUPPORT + 1] != 0.0) {
        const double *a = in + I_SOLES, *b = in + I_SOLES + 3;
        double ba[2] = {b[0] - a[0], b[1] - a[1]}, pa[2] = {pd[0] - a[0], pd[1] - a[1]};
        double bb = ba[0] * ba[0] + ba[1] * ba[1];
        double t = clip((pa[0] * ba[0] + pa[1] * ba[1]) / (bb > 1e-12 ? bb : 1e-12), 0.0, 1.0);
        d[0] = pd[0] - (a[0] + t * ba[0]), d[1] = pd[1] - (a[1] + t * ba[1]);
    } else {
        d[0] = pd[0] - in[I_SOLES + 3 * s], d[1] = pd[1] - in[I_SOLES + 3 * s + 1];
    }
    double c = cos(in[I_YAW + s]), sn = sin(in[I_YAW + s]);
    o[0] = clip(c * d[0] + sn * d[1], -in[I_SIZE] / 2, in[I_SIZE] / 2);
    o[1] = clip(-sn * d[0] + c * d[1], -in[I_SIZE + 1] / 2, in[I_SIZE + 1] / 2);
}

/* the estimate: the COM (world, anchored on the anchor soles) into out, the measured ZMP (0: none
 * loaded), each sole's load and CoP relative to its centre (foot frame) */
static int estimate(const hs_params *p, const double *in, double *st, double *out, double *zmp, double *loads,
                    double cops[2][2]) {
    const double *sup = in + I_ANCHORS, *ms = in + I_MSOLES;
    double diff[6], anchor[3], rel[3], centre[3];
    for (int i = 0; i < 6; i++) diff[i] = in[I_SOLES + i] - ms[i];
    mean_rows(diff, sup, anchor);
    mean_rows(ms, sup, centre);
    for (int i = 0; i < 3; i++) rel[i] = in[I_C + i] - centre[i];
    for (int s = 0; s < 2; s++) st[S_SWINGZ + s] = ms[3 * s + 2] + anchor[2];
    if (st[S_HASPREV] != 0.0 && (sup[0] != 0.0) == (st[S_SUPPREV] != 0.0) &&
        (sup[1] != 0.0) == (st[S_SUPPREV + 1] != 0.0)) {
        double a = 1.0 - exp(-2 * M_PI * p->velocity_cutoff_hz * p->dt);
        for (int i = 0; i < 3; i++) st[S_V + i] += a * ((rel[i] - st[S_RELPREV + i]) / p->dt - st[S_V + i]);
    }
    for (int i = 0; i < 3; i++) st[S_RELPREV + i] = rel[i];
    st[S_HASPREV] = 1.0, st[S_SUPPREV] = sup[0] != 0.0, st[S_SUPPREV + 1] = sup[1] != 0.0;
    double vel[3];
    mean_rows(in + I_SOLEVEL, sup, vel);
    for (int i = 0; i < 3; i++) st[S_VWORLD + i] = st[S_V + i] + vel[i];
    double fz = 0.0, num[2] = {0.0, 0.0};
    for (int s = 0; s < 2; s++) {
        const double *R = in + I_ROTS + 9 * s, *f = in + I_FORCE + 3 * s, *t = in + I_TORQUE + 3 * s;
        double fw[3], nw[3];
        for (int i = 0; i < 3; i++) {
            fw[i] = R[3 * i] * f[0] + R[3 * i + 1] * f[1] + R[3 * i + 2] * f[2];
            nw[i] = R[3 * i] * t[0] + R[3 * i + 1] * t[1] + R[3 * i + 2] * t[2];
        }
        loads[s] = 0.0, cops[s][0] = cops[s][1] = 0.0;
        if (fw[2] < p->min_load) continue;
        double pt[3];
        for (int i = 0; i < 3; i++) pt[i] = in[I_PTS + 3 * s + i] + anchor[i];
        double h = pt[2] - in[I_SOLES + 3 * s + 2];
        double z[2] = {pt[0] - (nw[1] + h * fw[0]) / fw[2], pt[1] - (h * fw[1] - nw[0]) / fw[2]};
        fz = fz + fw[2], num[0] = num[0] + fw[2] * z[0], num[1] = num[1] + fw[2] * z[1];
        loads[s] = fw[2];
        double d[2] = {z[0] - in[I_SOLES + 3 * s], z[1] - in[I_SOLES + 3 * s + 1]};
        cops[s][0] = R[0] * d[0] + R[3] * d[1], cops[s][1] = R[1] * d[0] + R[4] * d[1];
    }
    for (int i = 0; i < 3; i++) out[O_COM + i] = in[I_C + i] + anchor[i];
    if (fz > 0) zmp[0] = num[0] / fz, zmp[1] = num[1] / fz;
    return !isnan(zmp[0]) && !isnan(zmp[1]); /* none loaded, or a sensor's NaN: not measured */
}

/* the ankles' damping control: each loaded support sole's tilt towards its share of p_d */
static void ankles(const hs_params *p, const double *in, double *st, const double *pd, const double *loads,
                   double cops[2][2]) {
    for (int s = 0; s < 2; s++) {
        double *tilt = st + S_TILT + 2 * s;
        if (in[I_SUPPORT + s] == 0.0 || loads[s] <= 0.0 || fabs(in[I_PITCH + s]) > p->toe_off) {
            tilt[0] *= 1.0 - p->dt / p->ankle_return, tilt[1] *= 1.0 - p->dt / p->ankle_return;
            continue;
        }
        double want[2];
        foot_cop(in, s, pd, want);
        double err[2] = {loads[s] * (cops[s][1] - want[1]), loads[s] * -(cops[s][0] - want[0])};
        for (int i = 0; i < 2; i++) {
            double rate = err[i] / p->ankle_damping - tilt[i] / p->ankle_return;
            tilt[i] = clip(tilt[i] + rate * p->dt, -p->ankle_tilt_max, p->ankle_tilt_max);
        }
    }
}

/* A x = b by LU with partial pivoting (A: n x n, overwritten); 1 when A is singular */
static int solve(double *A, double *b, int n) {
    for (int k = 0; k < n; k++) {
        int piv = k;
        for (int i = k + 1; i < n; i++)
            if (fabs(A[i * n + k]) > fabs(A[piv * n + k])) piv = i;
        if (A[piv * n + k] == 0.0) return 1;
        if (piv != k) {
            for (int j = 0; j < n; j++) {
                double t = A[k * n + j];
                A[k * n + j] = A[piv * n + j], A[piv * n + j] = t;
            }
            double t = b[k];
            b[k] = b[piv], b[piv] = t;
        }
        for (int i = k + 1; i < n; i++) {
            double l = A[i * n + k] / A[k * n + k];
            for (int j = k + 1; j < n; j++) A[i * n + j] -= l * A[k * n + j];
            b[i] -= l * b[k];
        }
    }
    for (int i = n - 1; i >= 0; i--) {
        double s = b[i];
        for (int j = i + 1; j < n; j++) s -= A[i * n + j] * b[j];
        b[i] = s / A[i * n + i];
    }
    return 0;
}

/* the correction: joint changes (nv, the base's six first) moving the COM by dc, tilting and
 * lifting the soles, holding the rest (the rows' order: COM 3, each sole 6, the waist 3) */
static int correction(const hs_params *p, const double *in, const double *st, double *dq) {
    int n = p->nv;
    double A[MAX_NV * MAX_NV];
    memcpy(A, in + I_A, sizeof(double) * (size_t)(n * n));
    memset(dq, 0, sizeof(double) * (size_t)n);
    dq[0] = st[S_DC], dq[1] = st[S_DC + 1];
    for (int s = 0; s < 2; s++) {
        const double *R = in + I_RSOLE + 9 * s, *tilt = st + S_TILT + 2 * s;
        dq[3 + 6 * s + 2] = st[S_LIFT + s];
        for (int i = 0; i < 3; i++) dq[3 + 6 * s + 3 + i] = R[3 * i] * tilt[0] + R[3 * i + 1] * tilt[1] + R[3 * i + 2] * 0.0;
    }
    return solve(A, dq, n);
}

void humanoid_tick(const hs_params *p, const double *in, double *st, double *out) {
    double zmp[2] = {NAN, NAN}, loads[2], cops[2][2];
    int measured = estimate(p, in, st, out, zmp, loads, cops);
    const double *rc = in + I_COM, *rz = in + I_ZMP;
    double h = rc[2] - in[I_GROUND];
    double omega = sqrt(in[I_GRAVITY] / (0.2 > h ? 0.2 : h)), w2 = omega * omega; /* Python's max(h, 0.2) */
    double c[2] = {out[O_COM] + st[S_OFFSET], out[O_COM + 1] + st[S_OFFSET + 1]};
    if (measured) {
        for (int i = 0; i < 2; i++) {
            double implied = (c[i] - rc[i]) - st[S_ACC + i] / w2;
            st[S_OFFSET + i] += p->offset_rate * p->dt * ((zmp[i] - rz[i]) - implied);
        }
    }
    double xi[2], pd[2];
    for (int i = 0; i < 2; i++) {
        xi[i] = c[i] + st[S_VWORLD + i] / omega;
        double xi_ref = rc[i] + in[I_COMV + i] / omega;
        pd[i] = rz[i] + (1 + p->dcm_gain / omega) * (xi[i] - xi_ref);
    }
    clamp(p, in, pd);
    int singular = 0;
    if (p->enabled != 0.0) {
        for (int i = 0; i < 2; i++) {
            if (p->lip != 0.0) {
                st[S_ACC + i] = w2 * ((c[i] - rc[i]) - (pd[i] - rz[i]));
                st[S_DV + i] += st[S_ACC + i] * p->dt;
            } else {
                double xi_ref = rc[i] + in[I_COMV + i] / omega;
                double v_new = -p->com_velocity_gain * (xi[i] - xi_ref);
                st[S_ACC + i] = (v_new - st[S_DV + i]) / p->dt, st[S_DV + i] = v_new;
            }
        }
        for (int i = 0; i < 2; i++) st[S_DC + i] += st[S_DV + i] * p->dt;
        double n = sqrt(st[S_DC] * st[S_DC] + st[S_DC + 1] * st[S_DC + 1]);
        if (n > p->com_shift_max) {
            for (int i = 0; i < 2; i++) st[S_DC + i] *= p->com_shift_max / n, st[S_DV + i] = 0.0;
        }
        ankles(p, in, st, pd, loads, cops);
        for (int s = 0; s < 2; s++) {
            if (in[I_SUPPORT + s] != 0.0)
                st[S_LIFT + s] *= 1.0 - p->dt / p->swing_return;
            else
                st[S_LIFT + s] += p->swing_height_gain * p->dt * (in[I_SOLES + 3 * s + 2] - st[S_SWINGZ + s]);
        }
        singular = correction(p, in, st, out + O_DQ);
    } else {
        memset(out + O_DQ, 0, sizeof(double) * (size_t)p->nv);
    }
    out[O_XI] = xi[0], out[O_XI + 1] = xi[1], out[O_ZMP] = zmp[0], out[O_ZMP + 1] = zmp[1];
    out[O_PD] = pd[0], out[O_PD + 1] = pd[1], out[O_DC] = st[S_DC], out[O_DC + 1] = st[S_DC + 1];
    out[O_SINGULAR] = singular;
}
