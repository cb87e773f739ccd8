/* The state estimator's tick (skatelib.control.estimator.estimator.StateEstimator.__call__) in C:
 * the same equations, in the same order, on the same state; the Python modules document them.
 * Built by skatelib.control.estimator.native with the system's C compiler and called by ctypes.
 * Matrices are row-major; a (3, 4) array of the feet's columns is stored as 12 doubles, row after
 * row. */
#include <math.h>
#include <string.h>

#define BOARD 1
#define GROUND 2
#define ON_DECK 1
#define ON_FLOOR 2
#define NX 10

typedef struct {
    /* the legs: per leg, 3 revolute joints (placement R, p in their parent; axis) and the foot's
     * placement in the last joint */
    double joint_R[4][3][9], joint_p[4][3][3], axis[4][3][3], foot_R[4][9], foot_p[4][3];
    /* figures and settings */
    double rho, g, touch_m, settle_s, floor_settle_s, deck_height, axis_depth;
    double k_tilt, att_gate, att_gravity, mount[9], gyro_bias[3];
    double q_proc[NX], foot_velocity2, foot_height2, gate, deck_prior;
    double mass, com_offset[3], compliance;
    double turn, tilt_from_velocity, moving_deck, deck_roll_on, has_body;
    /* the state */
    double R[9], omega[3], accel[3];
    double x[NX], P[NX * NX];
    double yaw, roll, yaw_rate, roll_rate, deck_pos[3], footholds[12], deck_R[9];
    double stance[4], down_since[4], last_t, has_last, now, used[4], give[4], accel_world[3];
} est_t;

/* inputs: t, gyro 3, accel 3, q 12, qd 12, plan 4, plan at t + liftoff 4 */
enum { IN_T = 0, IN_GYRO = 1, IN_ACCEL = 4, IN_Q = 7, IN_QD = 19, IN_PLAN = 31, IN_AHEAD = 35, IN_N = 39 };
/* outputs: trunk pos 3, R 9, v 3, omega 3, deck pos 3, deck R 9, deck v 3, deck omega 3, touch 4,
 * contact points 12 */
enum { OUT_P = 0, OUT_R = 3, OUT_V = 12, OUT_W = 15, OUT_DP = 18, OUT_DR = 21, OUT_DV = 30, OUT_DW = 33,
       OUT_TOUCH = 36, OUT_CP = 40, OUT_N = 52 };

static void cross3(const double *a, const double *b, double *o) {
    double o0 = a[1] * b[2] - a[2] * b[1], o1 = a[2] * b[0] - a[0] * b[2], o2 = a[0] * b[1] - a[1] * b[0];
    o[0] = o0; o[1] = o1; o[2] = o2;
}

static void matvec3(const double *M, const double *v, double *o) {
    double o0 = M[0] * v[0] + M[1] * v[1] + M[2] * v[2];
    double o1 = M[3] * v[0] + M[4] * v[1] + M[5] * v[2];
    double o2 = M[6] * v[0] + M[7] * v[1] + M[8] * v[2];
    o[0] = o0; o[1] = o1; o[2] = o2;
}

static void mattvec3(const double *M, const double *v, double *o) { /* M^T v */
    double o0 = M[0] * v[0] + M[3] * v[1] + M[6] * v[2];
    double o1 = M[1] * v[0] + M[4] * v[1] + M[7] * v[2];
    double o2 = M[2] * v[0] + M[5] * v[1] + M[8] * v[2];
    o[0] = o0; o[1] = o1; o[2] = o2;
}

static void matmul3(const double *A, const double *B, double *o) {
    double t[9];
    for (int i = 0; i < 3; i++)
        for (int j = 0; j < 3; j++) t[3 * i + j] = A[3 * i] * B[j] + A[3 * i + 1] * B[3 + j] + A[3 * i + 2] * B[6 + j];
    memcpy(o, t, sizeof t);
}

/* Rodrigues' formula (vec3.exp_so3) */
static void exp_so3(const double *w, double *o) {
    double x = w[0], y = w[1], z = w[2], a2 = x * x + y * y + z * z;
    if (a2 < 1e-18) {
        double t[9] = {1.0, -z, y, z, 1.0, -x, -y, x, 1.0};
        memcpy(o, t, sizeof t);
        return;
    }
    double a = sqrt(a2), s = sin(a) / a, c = (1.0 - cos(a)) / a2;
    double t[9] = {1.0 - c * (y * y + z * z), c * x * y - s * z, c * x * z + s * y,
                   c * x * y + s * z, 1.0 - c * (x * x + z * z), c * y * z - s * x,
                   c * x * z - s * y, c * y * z + s * x, 1.0 - c * (x * x + y * y)};
    memcpy(o, t, sizeof t);
}

static void board_rotations(double yaw, double roll, double *o) {
    double c = cos(yaw), s = sin(yaw), cr = cos(roll), sr = sin(roll);
    double t[9] = {c, -s * cr, s * sr, s, c * cr, -c * sr, 0.0, sr, cr};
    memcpy(o, t, sizeof t);
}

/* eigen-decomposition of a symmetric 3 x 3 matrix by cyclic Jacobi rotations: eigenvalues in w,
 * eigenvectors in V's columns */
static void sym_eig3(const double *S, double *w, double *V) {
    double A[9];
    memcpy(A, S, sizeof A);
    for (int i = 0; i < 9; i++) V[i] = (i % 4 == 0) ? 1.0 : 0.0;
    for (int sweep = 0; sweep < 50; sweep++) {
        double off = A[1] * A[1] + A[2] * A[2] + A[5] * A[5];
        double diag = A[0] * A[0] + A[4] * A[4] + A[8] * A[8];
        if (off <= 1e-32 * diag || off == 0.0) break;
        for (int p = 0; p < 2; p++)
            for (int q = p + 1; q < 3; q++) {
                double apq = A[3 * p + q];
                if (apq == 0.0) continue;
                double theta = (A[3 * q + q] - A[3 * p + p]) / (2.0 * apq);
                double t = (theta >= 0 ? 1.0 : -1.0) / (fabs(theta) + sqrt(theta * theta + 1.0));
                double c = 1.0 / sqrt(t * t + 1.0), s = t * c;
                for (int k = 0; k < 3; k++) { /* A = J^T A J */
                    double akp = A[3 * k + p], akq = A[3 * k + q];
                    A[3 * k + p] = c * akp - s * akq;
                    A[3 * k + q] = s * akp + c * akq;
                }
                for (int k = 0; k < 3; k++) {
                    double apk = A[3 * p + k], aqk = A[3 * q + k];
                    A[3 * p + k] = c * apk - s * aqk;
                    A[3 * q + k] = s * apk + c * aqk;
                }
                for (int k = 0; k < 3; k++) {
                    double vkp = V[3 * k + p], vkq = V[3 * k + q];
                    V[3 * k + p] = c * vkp - s * vkq;
                    V[3 * k + q] = s * vkp + c * vkq;
                }
            }
    }
    w[0] = A[0]; w[1] = A[4]; w[2] = A[8];
}

/* Cholesky solve of the SPD n x n system S X = B (B: n x m, overwritten by X); 0 if not SPD */
static int chol_solve(double *S, int n, double *B, int m) {
    for (int j = 0; j < n; j++) {
        double d = S[j * n + j];
        for (int k = 0; k < j; k++) d -= S[j * n + k] * S[j * n + k];
        if (!(d > 0.0)) return 0;
        d = sqrt(d);
        S[j * n + j] = d;
        for (int i = j + 1; i < n; i++) {
            double v = S[i * n + j];
            for (int k = 0; k < j; k++) v -= S[i * n + k] * S[j * n + k];
            S[i * n + j] = v / d;
        }
    }
    for (int c = 0; c < m; c++) {
        for (int i = 0; i < n; i++) {
            double v = B[i * m + c];
            for (int k = 0; k < i; k++) v -= S[i * n + k] * B[k * m + c];
            B[i * m + c] = v / S[i * n + i];
        }
        for (int i = n - 1; i >= 0; i--) {
            double v = B[i * m + c];
            for (int k = i + 1; k < n; k++) v -= S[k * n + i] * B[k * m + c];
            B[i * m + c] = v / S[i * n + i];
        }
    }
    return 1;
}

/* the legs (legs.LegTermsBuffer): foot centres r (3 x 4), linear and angular Jacobians J, Jw
 * (4 x 3 x 3: row = world axis, column = the leg's joint) in the trunk frame */
static void legs(const est_t *s, const double *q, double *r, double *J, double *Jw) {
    for (int i = 0; i < 4; i++) {
        double Rw[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1}, pw[3] = {0, 0, 0}, ax[3][3], pj[3][3];
        for (int k = 0; k < 3; k++) {
            double t[3], Rj[9], w[3];
            matvec3(Rw, s->joint_p[i][k], t);
            for (int a = 0; a < 3; a++) pw[a] += t[a];
            matmul3(Rw, s->joint_R[i][k], Rw);
            for (int a = 0; a < 3; a++) w[a] = s->axis[i][k][a] * q[3 * i + k];
            matvec3(Rw, s->axis[i][k], ax[k]);
            exp_so3(w, Rj);
            matmul3(Rw, Rj, Rw);
            memcpy(pj[k], pw, sizeof pw);
        }
        double t[3], foot[3];
        matvec3(Rw, s->foot_p[i], t);
        for (int a = 0; a < 3; a++) foot[a] = pw[a] + t[a];
        for (int a = 0; a < 3; a++) r[4 * a + i] = foot[a];
        for (int k = 0; k < 3; k++) {
            double d[3] = {foot[0] - pj[k][0], foot[1] - pj[k][1], foot[2] - pj[k][2]}, c[3];
            cross3(ax[k], d, c);
            for (int a = 0; a < 3; a++) {
                J[9 * i + 3 * a + k] = c[a];
                Jw[9 * i + 3 * a + k] = ax[k][a];
            }
        }
    }
}

/* attitude.AttitudeFilter.update */
static void attitude(est_t *s, const double *gyro, const double *accel, double dt, const double *accel_world,
                     const double *accel_bias) {
    double omega[3] = {gyro[0] - s->gyro_bias[0], gyro[1] - s->gyro_bias[1], gyro[2] - s->gyro_bias[2]};
    double a[3] = {accel[0], accel[1], accel[2]}, f[3], w[3], E[9];
    if (s->turn != 0.0) {
        matvec3(s->mount, omega, omega);
        matvec3(s->mount, a, a);
    }
    memcpy(f, a, sizeof f);
    if (accel_world) {
        double t[3];
        mattvec3(s->R, accel_world, t);
        for (int k = 0; k < 3; k++) f[k] -= t[k];
    }
    if (accel_bias)
        for (int k = 0; k < 3; k++) f[k] -= accel_bias[k];
    double norm = sqrt(f[0] * f[0] + f[1] * f[1] + f[2] * f[2]);
    memcpy(w, omega, sizeof w);
    if (fabs(norm - s->att_gravity) < s->att_gate * s->att_gravity) {
        double u[3] = {f[0] / norm, f[1] / norm, f[2] / norm}, c[3];
        cross3(u, s->R + 6, c);
        for (int k = 0; k < 3; k++) w[k] = omega[k] + s->k_tilt * c[k];
    }
    for (int k = 0; k < 3; k++) w[k] *= dt;
    exp_so3(w, E);
    matmul3(s->R, E, s->R);
    memcpy(s->omega, omega, sizeof omega);
    memcpy(s->accel, a, sizeof a);
}

/* odometry.LegOdometry.predict */
static void predict(est_t *s, double dt) {
    double *x = s->x, b[3] = {s->accel[0] - x[7], s->accel[1] - x[8], s->accel[2] - x[9]}, a[3];
    double F[NX * NX], T[NX * NX];
    matvec3(s->R, b, a);
    a[2] -= s->g;
    for (int k = 0; k < 3; k++) {
        x[k] += x[3 + k] * dt + 0.5 * a[k] * dt * dt;
        x[3 + k] += a[k] * dt;
    }
    memset(F, 0, sizeof F);
    for (int k = 0; k < NX; k++) F[k * NX + k] = 1.0;
    for (int k = 0; k < 3; k++) {
        F[k * NX + 3 + k] = dt;
        for (int j = 0; j < 3; j++) {
            F[k * NX + 7 + j] = -0.5 * dt * dt * s->R[3 * k + j];
            F[(3 + k) * NX + 7 + j] = -dt * s->R[3 * k + j];
        }
    }
    for (int i = 0; i < NX; i++) /* T = F P */
        for (int j = 0; j < NX; j++) {
            double v = 0.0;
            for (int k = 0; k < NX; k++) v += F[i * NX + k] * s->P[k * NX + j];
            T[i * NX + j] = v;
        }
    for (int i = 0; i < NX; i++) /* P = T F^T */
        for (int j = 0; j < NX; j++) {
            double v = 0.0;
            for (int k = 0; k < NX; k++) v += T[i * NX + k] * F[j * NX + k];
            s->P[i * NX + j] = v;
        }
    for (int k = 0; k < NX; k++) s->P[k * NX + k] += s->q_proc[k] * dt;
}

/* loads.static_loads: the loads f (n) of feet at dx, dy from the centre of mass carrying W */
static void static_loads(const double *dx, const double *dy, int n, double W, double *f) {
    int done = 0;
    if (n >= 3) { /* loads._min_norm_loads */
        double sx = 0, sy = 0, sxx = 0, syy = 0, sxy = 0;
        for (int k = 0; k < n; k++) {
            sx += dx[k]; sy += dy[k]; sxx += dx[k] * dx[k]; syy += dy[k] * dy[k]; sxy += dx[k] * dy[k];
        }
        double c0 = sxx * syy - sxy * sxy, c1 = sy * sxy - sx * syy, c2 = sx * sxy - sy * sxx;
        double det = n * c0 + sx * c1 + sy * c2, big = n * sxx * syy;
        if (fabs(det) > 1e-12 * (big > 1.0 ? big : 1.0)) {
            double w = W / det;
            for (int k = 0; k < n; k++) f[k] = w * (c0 + c1 * dx[k] + c2 * dy[k]);
            done = 1;
        }
    }
    if (!done) { /* the minimum-norm least-squares loads: A^T (A A^T)^+ b, A = [1; dx; dy] (3 x n);
                  * A A^T's eigenvalues below 1e-10 of its largest taken as zero (A's singular values
                  * below 1e-5 of its largest: numpy's lstsq cuts at 1e-15, which A A^T's rounding
                  * cannot resolve; the two differ only for feet within 1e-5 of a line) */
        double M[9] = {0}, ev[3], V[9], y[3] = {0, 0, 0}, emax = 0.0;
        double *rows[3] = {NULL, dx, dy};
        for (int i = 0; i < 3; i++)
            for (int j = 0; j < 3; j++)
                for (int k = 0; k < n; k++)
                    M[3 * i + j] += (i ? rows[i][k] : 1.0) * (j ? rows[j][k] : 1.0);
        sym_eig3(M, ev, V);
        for (int i = 0; i < 3; i++) emax = fmax(emax, ev[i]);
        for (int i = 0; i < 3; i++) /* y = (A A^T)^+ b, b = (W, 0, 0) */
            if (ev[i] > 1e-10 * emax)
                for (int a = 0; a < 3; a++) y[a] += V[3 * a + i] * V[i] * W / ev[i];
        for (int k = 0; k < n; k++) f[k] = y[0] + y[1] * dx[k] + y[2] * dy[k];
    }
    for (int k = 0; k < n; k++) f[k] = f[k] > 0.0 ? (f[k] < W ? f[k] : W) : 0.0; /* within [0, W] */
}

/* loads.compressions: each stance foot's give, for the feet in idx (n of them) */
static void compressions(est_t *s, const double *centres, const int *idx, int n, const double *com) {
    for (int k = 0; k < 4; k++) s->give[k] = 0.0;
    if (!(s->compliance > 0) || n == 0) return;
    double dx[4], dy[4], f[4];
    for (int k = 0; k < n; k++) {
        dx[k] = centres[idx[k]] - com[0];
        dy[k] = centres[4 + idx[k]] - com[1];
    }
    static_loads(dx, dy, n, s->mass * s->g, f);
    for (int k = 0; k < n; k++) s->give[idx[k]] = s->compliance * f[k];
}

/* deck.plane_normal of n = 3 or 4 centres (columns idx) */
static void plane_normal(const double *c, const int *idx, int n, double *nrm) {
    if (n == 3) {
        double a[3], b[3];
        for (int k = 0; k < 3; k++) {
            a[k] = c[4 * k + idx[1]] - c[4 * k + idx[0]];
            b[k] = c[4 * k + idx[2]] - c[4 * k + idx[0]];
        }
        cross3(a, b, nrm);
        double l = sqrt(nrm[0] * nrm[0] + nrm[1] * nrm[1] + nrm[2] * nrm[2]);
        for (int k = 0; k < 3; k++) nrm[k] /= l;
    } else {
        double m[3] = {0, 0, 0}, S[9] = {0}, w[3], V[9];
        for (int k = 0; k < 3; k++) {
            for (int j = 0; j < n; j++) m[k] += c[4 * k + idx[j]];
            m[k] /= n;
        }
        for (int j = 0; j < n; j++) {
            double d[3] = {c[idx[j]] - m[0], c[4 + idx[j]] - m[1], c[8 + idx[j]] - m[2]};
            for (int a = 0; a < 3; a++)
                for (int b = 0; b < 3; b++) S[3 * a + b] += d[a] * d[b];
        }
        sym_eig3(S, w, V);
        int lo = 0;
        for (int k = 1; k < 3; k++) if (w[k] < w[lo]) lo = k;
        for (int k = 0; k < 3; k++) nrm[k] = V[3 * k + lo];
    }
    if (!(nrm[2] > 0))
        for (int k = 0; k < 3; k++) nrm[k] = -nrm[k];
}

typedef struct { double xby, ybx, zbx, xbx, yby, zby; } heading_fit_t;

static void heading_fit_init(heading_fit_t *h, const double *footholds, const double *c, const int *idx, int n) {
    double mf[3] = {0, 0, 0}, mb[2] = {0, 0};
    for (int j = 0; j < n; j++) {
        for (int k = 0; k < 3; k++) mf[k] += footholds[4 * k + idx[j]];
        for (int k = 0; k < 2; k++) mb[k] += c[4 * k + idx[j]];
    }
    memset(h, 0, sizeof *h);
    for (int j = 0; j < n; j++) {
        double fx = footholds[idx[j]] - mf[0] / n, fy = footholds[4 + idx[j]] - mf[1] / n;
        double fz = footholds[8 + idx[j]] - mf[2] / n;
        double bx = c[idx[j]] - mb[0] / n, by = c[4 + idx[j]] - mb[1] / n;
        h->xby += fx * by; h->ybx += fy * bx; h->zbx += fz * bx;
        h->xbx += fx * bx; h->yby += fy * by; h->zby += fz * by;
    }
}

static double heading_fit(const heading_fit_t *h, double roll) {
    double c = cos(roll), s = sin(roll);
    return atan2(h->xby - c * h->ybx + s * h->zbx, h->xbx + c * h->yby - s * h->zby);
}

/* deck.update_deck: the deck feet idx (n), their centres (3 x 4) and velocities (3 x 4) */
static void update_deck(est_t *s, const int *idx, int n, const double *c, const double *vel, double dt) {
    double yaw_rate = s->yaw_rate, roll_rate = s->roll_rate;
    if (n >= 2) { /* deck.deck_rates */
        const double *h = s->deck_R; /* column 0: R[0], R[3], R[6] */
        double hv[3] = {h[0], h[3], h[6]}, w2 = s->deck_prior * s->deck_prior;
        double a11 = 0, a12 = 0, a22 = 0, b1 = 0, b2 = 0;
        for (int i = 0; i < n; i++)
            for (int j = i + 1; j < n; j++) {
                double d[3], dv[3], c2[3];
                for (int k = 0; k < 3; k++) {
                    d[k] = c[4 * k + idx[i]] - c[4 * k + idx[j]];
                    dv[k] = vel[4 * k + idx[i]] - vel[4 * k + idx[j]];
                }
                double c1[3] = {-d[1], d[0], 0.0};
                cross3(hv, d, c2);
                for (int k = 0; k < 3; k++) {
                    a11 += c1[k] * c1[k]; a12 += c1[k] * c2[k]; a22 += c2[k] * c2[k];
                    b1 += c1[k] * dv[k]; b2 += c2[k] * dv[k];
                }
            }
        a11 += w2; a22 += w2;
        b1 += w2 * yaw_rate; b2 += w2 * roll_rate;
        double det = a11 * a22 - a12 * a12;
        yaw_rate = (a22 * b1 - a12 * b2) / det;
        roll_rate = (a11 * b2 - a12 * b1) / det;
    }
    double roll = s->roll + roll_rate * dt, yaw;
    heading_fit_t fit;
    if (n >= 2) {
        heading_fit_init(&fit, s->footholds, c, idx, n);
        yaw = heading_fit(&fit, roll);
    } else {
        yaw = s->yaw + yaw_rate * dt;
    }
    if (n >= 3) {
        double nrm[3];
        plane_normal(c, idx, n, nrm);
        for (int it = 0; it < 2; it++) {
            roll = atan2(sin(yaw) * nrm[0] - cos(yaw) * nrm[1], nrm[2]);
            yaw = heading_fit(&fit, roll);
        }
    }
    if (s->deck_roll_on == 0.0) {
        roll = roll_rate = 0.0;
        if (n >= 2) yaw = heading_fit(&fit, 0.0);
    }
    s->yaw = yaw; s->roll = roll; s->yaw_rate = yaw_rate; s->roll_rate = roll_rate;
    board_rotations(yaw, roll, s->deck_R);
    if (n) {
        double mc[3] = {0, 0, 0}, mf[3] = {0, 0, 0}, t[3];
        for (int k = 0; k < 3; k++)
            for (int j = 0; j < n; j++) {
                mc[k] += c[4 * k + idx[j]];
                mf[k] += s->footholds[4 * k + idx[j]];
            }
        for (int k = 0; k < 3; k++) mf[k] /= n;
        matvec3(s->deck_R, mf, t);
        for (int k = 0; k < 3; k++) s->deck_pos[k] = mc[k] / n - t[k];
    }
}

static void deck_omega(const est_t *s, double *w) {
    for (int k = 0; k < 3; k++) w[k] = s->roll_rate * s->deck_R[3 * k];
    w[2] += s->yaw_rate;
}

/* odometry.LegOdometry.correct_feet of the m feet idx: used[idx[j]] set */
static void correct_feet(est_t *s, const int *idx, int m, const double *on_deck, const double *rel,
                         const double *surface, const double *height) {
    double *x = s->x, *P = s->P, h[3] = {s->deck_R[0], s->deck_R[3], s->deck_R[6]};
    double d[4], target[3][4];
    int use[4], k = 0;
    for (int j = 0; j < m; j++) {
        d[j] = s->moving_deck != 0.0 ? on_deck[j] : 0.0;
        double nu[3], S[9], y[3];
        for (int a = 0; a < 3; a++) {
            target[a][j] = surface[4 * a + j] - rel[4 * a + idx[j]];
            nu[a] = target[a][j] - x[3 + a] + (d[j] * x[6]) * h[a];
        }
        for (int a = 0; a < 3; a++)
            for (int b = 0; b < 3; b++) {
                double v = P[(3 + a) * NX + 3 + b] + (a == b ? s->foot_velocity2 : 0.0);
                if (d[j] != 0.0)
                    v += -d[j] * (h[a] * P[(3 + b) * NX + 6] + P[(3 + a) * NX + 6] * h[b])
                         + d[j] * d[j] * P[6 * NX + 6] * h[a] * h[b];
                S[3 * a + b] = v;
            }
        memcpy(y, nu, sizeof y);
        double maha = NAN;
        if (chol_solve(S, 3, y, 1)) maha = nu[0] * y[0] + nu[1] * y[1] + nu[2] * y[2];
        use[j] = !(maha > s->gate);
        if (use[j]) k++;
        s->used[idx[j]] = use[j];
    }
    if (!k) return;
    int rows = 4 * k, r = 0;
    double H[16 * NX], z[16], HP[16 * NX], S[16 * 16], Kt[16 * NX], e[16];
    memset(H, 0, sizeof(double) * rows * NX);
    for (int j = 0; j < m; j++) {
        if (!use[j]) continue;
        for (int a = 0; a < 3; a++) {
            H[(r + a) * NX + 3 + a] = 1.0;
            H[(r + a) * NX + 6] = -d[j] * h[a];
            z[r + a] = target[a][j];
        }
        H[(r + 3) * NX + 2] = 1.0;
        z[r + 3] = height[j];
        r += 4;
    }
    /* H's rows have one or two entries (a velocity row: 1 at v_a, -d h_a at u; a height row: 1 at
     * p_z): H P and H P H^T by picking P's rows and H P's columns */
    for (int i = 0; i < rows; i++) {
        int a = i % 4;
        const double *Pa = P + (a == 3 ? 2 : 3 + a) * NX;
        double w = H[i * NX + 6];
        for (int c = 0; c < NX; c++) HP[i * NX + c] = Pa[c] + (a == 3 ? 0.0 : w * P[6 * NX + c]);
    }
    for (int i = 0; i < rows; i++)
        for (int j = 0; j < rows; j++) {
            int b = j % 4;
            double v = b == 3 ? HP[i * NX + 2] : HP[i * NX + 3 + b] + H[j * NX + 6] * HP[i * NX + 6];
            S[i * rows + j] = v + (i == j ? (b == 3 ? s->foot_height2 : s->foot_velocity2) : 0.0);
        }
    memcpy(Kt, HP, sizeof(double) * rows * NX);
    if (!chol_solve(S, rows, Kt, NX)) return;
    for (int i = 0; i < rows; i++) {
        double v = 0.0;
        for (int l = 0; l < NX; l++) v += H[i * NX + l] * x[l];
        e[i] = z[i] - v;
    }
    for (int c = 0; c < NX; c++) {
        double v = 0.0;
        for (int i = 0; i < rows; i++) v += Kt[i * NX + c] * e[i];
        x[c] += v;
    }
    for (int a = 0; a < NX; a++)
        for (int b = 0; b < NX; b++) {
            double v = 0.0;
            for (int i = 0; i < rows; i++) v += Kt[i * NX + a] * HP[i * NX + b];
            P[a * NX + b] -= v;
        }
}

/* StateEstimator._correct */
static void correct(est_t *s, const double *plan, const double *ahead, const double *centres, const double *rel,
                    const double *r) {
    int idx[4], m = 0;
    double on_deck[4], surface[12] = {0}, height[4], omega_b[3], axis[3];
    for (int i = 0; i < 4; i++) {
        s->used[i] = 0.0;
        int board = plan[i] == BOARD, ground = plan[i] == GROUND;
        int lifting = ground && ahead[i] != GROUND;
        double settle = board ? s->settle_s : s->floor_settle_s;
        if ((board || ground) && (s->now - s->down_since[i] >= settle) && !lifting) {
            on_deck[m] = board;
            idx[m++] = i;
        }
    }
    if (!m) return;
    deck_omega(s, omega_b);
    for (int k = 0; k < 3; k++) axis[k] = s->deck_pos[k] - s->axis_depth * s->deck_R[3 * k + 2];
    for (int j = 0; j < m; j++) {
        int i = idx[j];
        if (s->moving_deck != 0.0 && on_deck[j] != 0.0) {
            double dc[3] = {centres[i] - axis[0], centres[4 + i] - axis[1], centres[8 + i] - axis[2]}, sv[3];
            cross3(omega_b, dc, sv);
            for (int a = 0; a < 3; a++) surface[4 * a + j] = sv[a];
        }
        double target = s->rho;
        if (on_deck[j] != 0.0)
            target = s->deck_height - s->axis_depth
                     + (s->deck_R[6] * s->footholds[i] + s->deck_R[7] * s->footholds[4 + i]
                        + s->deck_R[8] * (s->footholds[8 + i] + s->axis_depth));
        target -= s->give[i];
        double rz = s->R[6] * r[i] + s->R[7] * r[4 + i] + s->R[8] * r[8 + i];
        height[j] = target - rz;
    }
    correct_feet(s, idx, m, on_deck, rel, surface, height);
}

void est_tick(est_t *s, const double *in, double *out) {
    double t = in[IN_T], dt = s->has_last != 0.0 ? t - s->last_t : 0.0;
    const double *plan = in + IN_PLAN, *qd = in + IN_QD;
    double r[12], J[36], Jw[36], rel[12], spin[12], normals[12], centres[12], v_before[3];
    s->last_t = s->now = t;
    s->has_last = 1.0;
    int known = s->tilt_from_velocity != 0.0;
    attitude(s, in + IN_GYRO, in + IN_ACCEL, dt, known ? s->accel_world : NULL, known ? s->x + 7 : NULL);
    memcpy(v_before, s->x + 3, sizeof v_before);
    if (dt > 0) predict(s, dt);
    legs(s, in + IN_Q, r, J, Jw);
    const double *R = s->R, *omega = s->omega, *p = s->x;
    for (int i = 0; i < 4; i++) {
        double ri[3] = {r[i], r[4 + i], r[8 + i]}, a[3], b[3], w[3], n[3], c[3];
        cross3(omega, ri, a);
        for (int k = 0; k < 3; k++) {
            a[k] += J[9 * i + 3 * k] * qd[3 * i] + J[9 * i + 3 * k + 1] * qd[3 * i + 1] + J[9 * i + 3 * k + 2] * qd[3 * i + 2];
            w[k] = omega[k] + Jw[9 * i + 3 * k] * qd[3 * i] + Jw[9 * i + 3 * k + 1] * qd[3 * i + 1]
                   + Jw[9 * i + 3 * k + 2] * qd[3 * i + 2];
        }
        matvec3(R, a, b);
        matvec3(R, w, spin + 3 * i);
        for (int k = 0; k < 3; k++) n[k] = plan[i] == BOARD ? s->deck_R[3 * k + 2] : (k == 2 ? 1.0 : 0.0);
        for (int k = 0; k < 3; k++) normals[4 * k + i] = n[k];
        double rn[3] = {s->rho * n[0], s->rho * n[1], s->rho * n[2]};
        cross3(spin + 3 * i, rn, c);
        matvec3(R, ri, a);
        for (int k = 0; k < 3; k++) {
            rel[4 * k + i] = b[k] - c[k];
            centres[4 * k + i] = p[k] + a[k];
        }
    }
    if (s->has_body != 0.0) {
        int idx[4], n = 0;
        double com[3];
        for (int i = 0; i < 4; i++)
            if (s->stance[i] != 0.0 && plan[i] != 0) idx[n++] = i;
        matvec3(R, s->com_offset, com);
        for (int k = 0; k < 3; k++) com[k] += p[k];
        compressions(s, centres, idx, n, com);
    }
    {
        double rigid[12], vel[12];
        int idx[4], n = 0;
        for (int i = 0; i < 4; i++) {
            for (int k = 0; k < 3; k++) {
                rigid[4 * k + i] = centres[4 * k + i] + s->give[i] * normals[4 * k + i];
                vel[4 * k + i] = s->x[3 + k] + rel[4 * k + i];
            }
            if (plan[i] == BOARD && s->stance[i] != 0.0) idx[n++] = i;
        }
        update_deck(s, idx, n, rigid, vel, dt);
    }
    correct(s, plan, in + IN_AHEAD, centres, rel, r);
    if (dt > 0)
        for (int k = 0; k < 3; k++) s->accel_world[k] = (s->x[3 + k] - v_before[k]) / dt;

    /* StateEstimator._state */
    double deck_n[3] = {s->deck_R[2], s->deck_R[5], s->deck_R[8]}, wb[3];
    for (int i = 0; i < 4; i++) {
        double ri[3] = {r[i], r[4 + i], r[8 + i]}, a[3];
        matvec3(R, ri, a);
        for (int k = 0; k < 3; k++) centres[4 * k + i] = p[k] + a[k];
    }
    for (int i = 0; i < 4; i++) {
        double over_deck = deck_n[0] * (centres[i] - s->deck_pos[0]) + deck_n[1] * (centres[4 + i] - s->deck_pos[1])
                           + deck_n[2] * (centres[8 + i] - s->deck_pos[2]) - s->rho;
        double over_floor = centres[8 + i] - s->rho;
        int deck_side = plan[i] == BOARD || (plan[i] != GROUND && fabs(over_deck) < fabs(over_floor));
        double gap = (deck_side ? over_deck : over_floor) + s->give[i];
        int touching = gap < s->touch_m;
        out[OUT_TOUCH + i] = touching ? (deck_side ? ON_DECK : ON_FLOOR) : 0;
        if (touching && deck_side && s->stance[i] == 0.0 && plan[i] == BOARD) {
            double d[3], hold[3];
            for (int k = 0; k < 3; k++) d[k] = centres[4 * k + i] + s->give[i] * deck_n[k] - s->deck_pos[k];
            mattvec3(s->deck_R, d, hold);
            s->footholds[i] = hold[0];
            s->footholds[4 + i] = hold[1];
            s->footholds[8 + i] = s->rho;
        }
        int stance = touching && plan[i] != 0;
        if (!stance) s->down_since[i] = INFINITY;
        else if (s->stance[i] == 0.0) s->down_since[i] = s->now;
        s->stance[i] = stance;
        for (int k = 0; k < 3; k++) {
            double n = deck_side ? deck_n[k] : (k == 2 ? 1.0 : 0.0);
            out[OUT_CP + 4 * k + i] = centres[4 * k + i] - s->rho * n;
        }
    }
    deck_omega(s, wb);
    double ad[3] = {s->axis_depth * deck_n[0], s->axis_depth * deck_n[1], s->axis_depth * deck_n[2]}, dv[3];
    cross3(wb, ad, dv);
    for (int k = 0; k < 3; k++) {
        out[OUT_P + k] = p[k];
        out[OUT_V + k] = s->x[3 + k];
        out[OUT_W + k] = omega[k];
        out[OUT_DP + k] = s->deck_pos[k];
        out[OUT_DV + k] = s->x[6] * s->deck_R[3 * k] + dv[k];
        out[OUT_DW + k] = wb[k];
    }
    memcpy(out + OUT_R, R, 9 * sizeof(double));
    memcpy(out + OUT_DR, s->deck_R, 9 * sizeof(double));
}

/* the legs' terms alone (for tests against pinocchio): r (12), J (36), Jw (36) into out */
void est_legs(const est_t *s, const double *q, double *out) { legs(s, q, out, out + 12, out + 48); }

/* the static loads alone (for tests against numpy's least squares): n <= 4 feet */
void est_static_loads(const double *dx, const double *dy, int n, double W, double *f) { static_loads(dx, dy, n, W, f); }
