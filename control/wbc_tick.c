/* The whole-body tick's targets (skatelib.control.wbc_targets.TargetMaker) and the assembly of its
 * QP from the default tasks and constraints (skatelib.control.wbc.WholeBodyController with
 * wbc_tasks.default_tasks and wbc_constraints.default_constraints) in C: the same equations, in the
 * same order; the Python modules document them. Built by skatelib.control.wbc_native with the
 * system's C compiler and called by ctypes. Matrices are row-major; a (3, 4) array of the feet's
 * columns is stored as 12 doubles, row after row. */
#include <math.h>
#include <float.h>
#include <string.h>

#define NV 18
#define ON_DECK 1
#define ON_FLOOR 2

typedef struct {
    double kp_com, kd_com, kp_att, kd_att, kp_swing, kd_swing, kp_post, kd_post, stance_gain;
    double mass, gravity, axis_depth, reach;
    double sw_com, sw_swing, w_att, w_post, w_force; /* sw: square roots of the dense tasks' weights */
    double q_diag[NV];                               /* the cost's fixed diagonal over qdd */
    double coef[5][3];                               /* a stance foot's surface rows (normal, facets) */
    double per_leg;                                  /* 5 with the friction rows, 1 without */
    double joints[12];                               /* the joints' columns of qdd, channel order */
} wbc_t;

/* targets: inputs */
enum { T_TR = 0, T_TW = 9, T_Q = 12, T_QD = 24, T_DP = 36, T_DR = 39, T_DV = 48, T_DW = 51, T_TOUCH = 54,
       T_YAW = 58, T_COM = 59, T_COMV = 62, T_FEET = 65, T_FEETV = 77, T_F = 89,
       B_COM = 101, B_COMV = 104, B_RPY = 107, B_W = 110, B_Q = 113, B_BV = 125, B_FEET = 128, B_FEETV = 140,
       B_FEETA = 152, T_PLANNED = 164, T_AHEAD = 168, T_DECKNEXT = 172, T_STANCE = 176, T_IN = 180 };
/* targets: outputs */
enum { O_STANCE = 0, O_ONDECK = 4, O_SACC = 8, O_COMACC = 20, O_ANG = 23, O_SWING = 26, O_POST = 38, T_OUT = 50 };
/* assembly: inputs (the dynamics terms, then the targets) */
enum { A_M = 0, A_H = 324, A_JF = 342, A_DJF = 558, A_JC = 570, A_DJC = 624, A_SACC = 627, A_COMACC = 639,
       A_ANG = 642, A_SWING = 645, A_POST = 657, A_F = 669, A_DR = 681, A_ONDECK = 690, A_LIMIT = 694, A_IN = 695 };

static void mat_vec(const double *R, const double *v, double *o) {
    double a = R[0] * v[0] + R[1] * v[1] + R[2] * v[2];
    double b = R[3] * v[0] + R[4] * v[1] + R[5] * v[2];
    double c = R[6] * v[0] + R[7] * v[1] + R[8] * v[2];
    o[0] = a, o[1] = b, o[2] = c;
}

static void mat_t_vec(const double *R, const double *v, double *o) {
    double a = R[0] * v[0] + R[3] * v[1] + R[6] * v[2];
    double b = R[1] * v[0] + R[4] * v[1] + R[7] * v[2];
    double c = R[2] * v[0] + R[5] * v[1] + R[8] * v[2];
    o[0] = a, o[1] = b, o[2] = c;
}

static void cross3(const double *a, const double *b, double *o) {
    double o0 = a[1] * b[2] - a[2] * b[1], o1 = a[2] * b[0] - a[0] * b[2], o2 = a[0] * b[1] - a[1] * b[0];
    o[0] = o0, o[1] = o1, o[2] = o2;
}

/* pinocchio's rpy.rpyToMatrix: Rz(y) Ry(p) Rx(r) */
static void rpy_matrix(double r, double p, double y, double *R) {
    double cr = cos(r), sr = sin(r), cp = cos(p), sp = sin(p), cy = cos(y), sy = sin(y);
    R[0] = cy * cp, R[1] = cy * sp * sr - sy * cr, R[2] = cy * sp * cr + sy * sr;
    R[3] = sy * cp, R[4] = sy * sp * sr + cy * cr, R[5] = sy * sp * cr - cy * sr;
    R[6] = -sp, R[7] = cp * sr, R[8] = cp * cr;
}

/* pinocchio's compute_theta_axis<i0> (log3 near theta = pi) */
static void theta_axis(int i0, double val, const double *R, double *angle, double *axis) {
    const double eps = DBL_EPSILON;
    int i1 = (i0 + 1) % 3, i2 = (i0 + 2) % 3;
    double s = sqrt(val + eps + eps * eps) * (R[3 * i2 + i1] >= R[3 * i1 + i2] ? 1.0 : -1.0);
    axis[i0] = s / 2;
    axis[i1] = 1 / (2 * s) * (R[3 * i1 + i0] + R[3 * i0 + i1]);
    axis[i2] = 1 / (2 * s) * (R[3 * i2 + i0] + R[3 * i0 + i2]);
    double w = 1 / (2 * s) * (R[3 * i2 + i1] - R[3 * i1 + i2]);
    double n = sqrt(axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]);
    *angle = 2 * atan2(n, w);
    axis[0] /= n, axis[1] /= n, axis[2] /= n;
}

/* pinocchio's log3 (spatial/log.hxx): the rotation renormalized, then its angle-axis vector */
static void log3(const double *Rin, double *out) {
    const double eps = DBL_EPSILON, prec = cbrt(DBL_EPSILON);
    double R[9], c0[3] = {Rin[0], Rin[3], Rin[6]}, c1[3] = {Rin[1], Rin[4], Rin[7]}, c2[3];
    double n0 = sqrt(c0[0] * c0[0] + c0[1] * c0[1] + c0[2] * c0[2]);
    double n1 = sqrt(c1[0] * c1[0] + c1[1] * c1[1] + c1[2] * c1[2]);
    for (int i = 0; i < 3; i++) c0[i] /= n0, c1[i] /= n1;
    cross3(c0, c1, c2);
    cross3(c1, c2, c0);
    for (int i = 0; i < 3; i++) R[3 * i] = c0[i], R[3 * i + 1] = c1[i], R[3 * i + 2] = c2[i];
    double tr = R[0] + R[4] + R[8], cos_value = (tr - 1) / 2;
    double acos_expansion = sqrt(2 * (1 - cos_value) + eps * eps);
    double theta = tr <= 3 - prec ? (tr >= -1 + prec ? acos(cos_value) : M_PI - acos_expansion) : acos_expansion;
    double a[3] = {0.5 * (R[7] - R[5]), 0.5 * (R[2] - R[6]), 0.5 * (R[3] - R[1])};
    double n2 = a[0] * a[0] + a[1] * a[1] + a[2] * a[2];
    double t = theta >= prec ? theta / sin(theta) : 1. + n2 / 6 + n2 * n2 * 3 / 40;
    if (cos_value >= -1 + prec) {
        for (int k = 0; k < 3; k++) out[k] = t * a[k];
        return;
    }
    double val[3], th[3], ax[3][3];
    for (int i = 0; i < 3; i++) val[i] = 2 * R[4 * i] - tr + 1;
    for (int i = 0; i < 3; i++) theta_axis(i, val[i], R, &th[i], ax[i]);
    int pick = val[0] >= val[1] ? (val[0] >= val[2] ? 0 : 2) : (val[1] >= val[2] ? 1 : 2);
    for (int k = 0; k < 3; k++) out[k] = th[pick] * ax[pick][k];
}

/* TargetMaker.__call__ (and its _feet) after the plan's row and the contact table's codes */
void wbc_targets(const wbc_t *s, const double *in, double *out) {
    const double *R = in + T_TR, *dR = in + T_DR, *dp = in + T_DP, *dv = in + T_DV, *dw = in + T_DW;
    const double *touch = in + T_TOUCH, *feet = in + T_FEET, *feet_v = in + T_FEETV, *forces = in + T_F;
    double yaw = in[T_YAW], cy = cos(yaw), sy = sin(yaw);
    double Ry[9] = {cy, -sy, 0, sy, cy, 0, 0, 0, 1};
    double level[3], up[3] = {0, 0, 1}, stance[4], v_ref[3], rel[3], sum[3] = {0, 0, 0};
    for (int i = 0; i < 3; i++) level[i] = dp[i] + s->axis_depth * (up[i] - dR[3 * i + 2]);
    for (int l = 0; l < 4; l++) {
        int touching = touch[l] > 0, planned = in[T_PLANNED + l] > 0.5;
        int early = touching && in[T_AHEAD + l] > 0.5;
        stance[l] = (planned || early) && (touching || in[T_STANCE + l] > 0.5);
        out[O_STANCE + l] = stance[l];
    }
    mat_vec(Ry, in + B_COMV, v_ref);
    v_ref[0] += dv[0], v_ref[1] += dv[1];
    mat_vec(Ry, in + B_COM, rel);
    for (int i = 0; i < 3; i++)
        for (int l = 0; l < 4; l++)
            if (in[T_PLANNED + l] > 0.5) sum[i] += forces[4 * i + l];
    for (int i = 0; i < 3; i++)
        out[O_COMACC + i] = sum[i] / s->mass - s->gravity * up[i] + s->kp_com * (level[i] + rel[i] - in[T_COM + i])
                            + s->kd_com * (v_ref[i] - in[T_COMV + i]);
    /* the trunk's attitude: log3(Rp R^T) turned into the trunk frame */
    double Rp[9], E[9], l3[3], ang[3];
    rpy_matrix(in[B_RPY], in[B_RPY + 1], in[B_RPY + 2] + yaw, Rp);
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++)
            E[3 * i + j] = Rp[3 * i] * R[3 * j] + Rp[3 * i + 1] * R[3 * j + 1] + Rp[3 * i + 2] * R[3 * j + 2];
    log3(E, l3);
    mat_t_vec(R, l3, ang);
    for (int i = 0; i < 3; i++)
        out[O_ANG + i] = s->kp_att * ang[i] + s->kd_att * (in[B_W + i] - in[T_TW + i]);
    /* the feet */
    for (int l = 0; l < 4; l++) {
        int deck = in[T_DECKNEXT + l] > 0.5;
        double bf[3] = {in[B_FEET + l], in[B_FEET + 4 + l], in[B_FEET + 8 + l]};
        double bv[3] = {in[B_FEETV + l], in[B_FEETV + 4 + l], in[B_FEETV + 8 + l]};
        double ba[3] = {in[B_FEETA + l], in[B_FEETA + 4 + l], in[B_FEETA + 8 + l]};
        double target[3], tv[3], ra[3], normal[3];
        if (deck) {
            mat_vec(dR, bf, target);
            for (int i = 0; i < 3; i++) target[i] += dp[i];
        } else {
            mat_vec(Ry, bf, target);
            for (int i = 0; i < 3; i++) target[i] += level[i];
            for (int i = 0; i < 3; i++) bv[i] += in[B_BV + i];
        }
        mat_vec(Ry, bv, tv);
        for (int i = 0; i < 3; i++) tv[i] += deck ? dv[i] : 0.0;
        int on_deck = touch[l] == ON_DECK || (touch[l] == 0 && deck);
        out[O_ONDECK + l] = on_deck;
        for (int i = 0; i < 3; i++) normal[i] = on_deck ? dR[3 * i + 2] : up[i];
        int reach = in[T_PLANNED + l] > 0.5 && !stance[l];
        for (int i = 0; i < 3; i++) target[i] -= s->reach * (normal[i] * reach);
        mat_vec(Ry, ba, ra);
        for (int i = 0; i < 3; i++)
            out[O_SWING + 4 * i + l] = ra[i] + s->kp_swing * (target[i] - feet[4 * i + l])
                                      + s->kd_swing * (tv[i] - feet_v[4 * i + l]);
        /* a stance foot moves with its deck point, or stays on the floor */
        double r[3] = {feet[l] - dp[0], feet[4 + l] - dp[1], feet[8 + l] - dp[2]}, spin[3], ws[3];
        cross3(dw, r, spin);
        cross3(dw, spin, ws);
        for (int i = 0; i < 3; i++)
            out[O_SACC + 4 * i + l] = touch[l] == ON_FLOOR ? -s->stance_gain * feet_v[4 * i + l]
                                      : ws[i] + s->stance_gain * (dv[i] + spin[i] - feet_v[4 * i + l]);
    }
    for (int j = 0; j < 12; j++)
        out[O_POST + j] = s->kp_post * (in[B_Q + j] - in[T_Q + j]) - s->kd_post * in[T_QD + j];
}

/* WholeBodyController._assemble with the default tasks and constraints for the stance feet ``legs``
 * (``ns`` of them, ascending) and the swinging ``swing`` (4 - ns): the cost's H (its qdd block; the
 * rest is fixed) and g, the constraints' rows (what changes; the rest is fixed) and bounds. */
void wbc_assemble(const wbc_t *s, const int *legs, int ns, const double *in, double *H, double *g, double *rows,
                  double *lo, double *up) {
    int swing[4], nw = 0, n = NV + 3 * ns, per_leg = (int)s->per_leg;
    for (int l = 0, k = 0; l < 4; l++) {
        if (k < ns && legs[k] == l) k++;
        else swing[nw++] = l;
    }
    /* the dense tasks' weighted rows over qdd: the COM's, then each swinging foot's */
    double A[15][NV], b[15];
    int nr = 3 + 3 * nw;
    for (int i = 0; i < 3; i++) {
        for (int c = 0; c < NV; c++) A[i][c] = s->sw_com * in[A_JC + NV * i + c];
        b[i] = s->sw_com * (in[A_COMACC + i] - in[A_DJC + i]);
    }
    for (int k = 0; k < nw; k++) {
        int l = swing[k];
        for (int i = 0; i < 3; i++) {
            const double *J = in + A_JF + 3 * NV * l + NV * i;
            for (int c = 0; c < NV; c++) A[3 + 3 * k + i][c] = s->sw_swing * J[c];
            b[3 + 3 * k + i] = s->sw_swing * (in[A_SWING + 4 * i + l] - in[A_DJF + 3 * l + i]);
        }
    }
    for (int i = 0; i < NV; i++) {
        for (int j = i; j < NV; j++) {
            double acc = 0;
            for (int r = 0; r < nr; r++) acc += A[r][i] * A[r][j];
            H[n * i + j] = H[n * j + i] = acc;
        }
        H[n * i + i] += s->q_diag[i];
        double acc = 0;
        for (int r = 0; r < nr; r++) acc += A[r][i] * b[r];
        g[i] = -acc;
    }
    for (int i = 0; i < 3; i++) g[3 + i] -= s->w_att * in[A_ANG + i];
    for (int j = 0; j < 12; j++) g[(int)s->joints[j]] -= s->w_post * in[A_POST + j];
    for (int k = 0; k < ns; k++)
        for (int i = 0; i < 3; i++) g[NV + 3 * k + i] = -s->w_force * in[A_F + 4 * i + legs[k]];
    /* the generalized forces (M qdd + h - J_c^T f): zero on the base, the joints' torques bounded */
    double limit = in[A_LIMIT];
    for (int r = 0; r < NV; r++) {
        double *row = rows + n * r;
        memcpy(row, in + A_M + NV * r, NV * sizeof(double));
        for (int k = 0; k < ns; k++)
            for (int i = 0; i < 3; i++) row[NV + 3 * k + i] = -in[A_JF + 3 * NV * legs[k] + NV * i + r];
        double band = r < 6 ? 0.0 : limit, h = in[A_H + r];
        up[r] = band - h;
        lo[r] = -band - h;
    }
    /* the stance feet's accelerations */
    for (int k = 0; k < ns; k++)
        for (int i = 0; i < 3; i++) {
            int r = NV + 3 * k + i, l = legs[k];
            memcpy(rows + n * r, in + A_JF + 3 * NV * l + NV * i, NV * sizeof(double));
            up[r] = lo[r] = in[A_SACC + 4 * i + l] - in[A_DJF + 3 * l + i];
        }
    /* each stance foot's normal and friction facets about its surface's normal */
    const double *dR = in + A_DR;
    int base = NV + 3 * ns;
    for (int k = 0; k < ns; k++) {
        int on_deck = in[A_ONDECK + legs[k]] > 0.5;
        for (int p = 0; p < per_leg; p++) {
            double *row = rows + n * (base + per_leg * k + p);
            const double *c = s->coef[p];
            for (int i = 0; i < 3; i++)
                row[NV + 3 * k + i] = on_deck ? c[0] * dR[3 * i] + c[1] * dR[3 * i + 1] + c[2] * dR[3 * i + 2] : c[i];
        }
    }
}
