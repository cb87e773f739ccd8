/* The quadruped twin's physics steps with the wheels' rolling torques, and its readout, in C:
 * skatelib.sim.plant's TwinPlant.step and TwinPlant.state (skatelib.sim.rolling,
 * skatelib.sim.contacts), and the humanoid twin's steps (its shove, its board's rolling torques),
 * the same MuJoCo calls and the same arithmetic in the same order, called
 * through ctypes once per whole-body tick instead of some hundred small Python and numpy calls.
 * Built with -ffp-contract=off against the MuJoCo library of the Python package (its headers and
 * its libmujoco), on the model and data of the Python bindings (their _address). */

#include <math.h>
#include <string.h>
#include <mujoco/mujoco.h>

typedef struct {
    int wheel_geom[4], wheel_dof[4], wheel_act[4];
    double radius[4];
    double coefficient, smoothing;
    int floor;
} rolling_t;

typedef struct {
    rolling_t roll;
    int robot_act[12];
    int deck_geom;
    int feet[4];
    double foot_radius;
    int trunk, deck, trunk_q, trunk_v, deck_v;
    int qadr[12], dadr[12];
    const int *foot_of;            /* ngeom: each geom's foot, -1 for none */
    const unsigned char *planned;  /* ngeom: a foot or a wheel (its place is on the floor) */
} twin_t;

/* The readout's layout (skatelib.sim.native's S_ offsets). */
enum {
    S_T = 0, S_TRUNK_POS = 1, S_TRUNK_R = 4, S_TRUNK_V = 13, S_TRUNK_W = 16, S_Q = 19, S_QD = 31,
    S_DECK_POS = 43, S_DECK_R = 46, S_DECK_V = 55, S_DECK_W = 58, S_CENTRES = 61, S_FOOT_V = 73,
    S_SPINS = 85, S_POINTS = 97, S_FOOT_LOAD = 109, S_WHEEL_LOAD = 113, S_WHEEL_FORCE = 117,
    S_SYSTEM_V = 120, S_TOUCH = 123, S_N_STRAY = 127, S_STRAY = 128, N_STRAY = 8, S_N = 136
};

/* The wheel of a contact of a wheel with the floor, else -1. */
static int wheel_of(const rolling_t *r, int g1, int g2)
{
    for (int i = 0; i < 4; i++)
        if ((g1 == r->floor && g2 == r->wheel_geom[i]) || (g2 == r->floor && g1 == r->wheel_geom[i]))
            return i;
    return -1;
}

/* Each wheel's normal force on the floor (RollingResistance.floor_forces), and the floor's force
 * on the four wheels, world frame, when total is not NULL. */
static void wheel_forces(const mjModel *m, const mjData *d, const rolling_t *r, double *loads, double *total)
{
    double f[6];
    for (int i = 0; i < 4; i++) loads[i] = 0.0;
    if (total) total[0] = total[1] = total[2] = 0.0;
    for (int k = 0; k < d->ncon; k++) {
        const mjContact *c = d->contact + k;
        int w = wheel_of(r, c->geom[0], c->geom[1]);
        if (w < 0) continue;
        mj_contactForce(m, d, k, f);
        loads[w] += f[0];
        if (!total) continue;
        int second = c->geom[1] != r->floor;  /* the force is on geom 2: the wheel, or the floor */
        for (int j = 0; j < 3; j++) {
            double force = c->frame[j] * f[0] + c->frame[3 + j] * f[1] + c->frame[6 + j] * f[2];
            total[j] += second ? force : -force;
        }
    }
}

/* n physics steps, the rolling torques before each (RollingResistance.apply; r NULL: no board);
 * loads (4): the wheels' loads of the contacts as they are for the first step, or NULL. With
 * shove_body >= 0 a force shove[0] along y on that body before each step while
 * shove[1] <= time < shove[1] + shove[2], none otherwise (HumanoidErrors.push). */
void rolling_steps(const mjModel *m, mjData *d, const rolling_t *r, int n, const double *loads, int shove_body,
                   const double *shove)
{
    double own[4];
    for (int k = 0; k < n; k++) {
        if (shove_body >= 0) {
            int on = shove[0] != 0.0 && shove[1] <= d->time && d->time < shove[1] + shove[2];
            d->xfrc_applied[6 * shove_body] = 0.0;
            d->xfrc_applied[6 * shove_body + 1] = on ? shove[0] : 0.0;
            d->xfrc_applied[6 * shove_body + 2] = 0.0;
        }
        if (r) {
            const double *l = loads;
            if (k > 0 || !loads) {
                wheel_forces(m, d, r, own, NULL);
                l = own;
            }
            for (int i = 0; i < 4; i++) {
                double v = d->qvel[r->wheel_dof[i]] * r->radius[i];
                d->ctrl[r->wheel_act[i]] = -r->coefficient * r->radius[i] * l[i] * tanh(v / r->smoothing);
            }
        }
        mj_step(m, d);
    }
}

/* The quadruped's n steps with the joint torques tau (12) (TwinPlant.step). */
void twin_step(const mjModel *m, mjData *d, const twin_t *t, const double *tau, int n, const double *loads)
{
    for (int i = 0; i < 12; i++) d->ctrl[t->robot_act[i]] = tau[i];
    rolling_steps(m, d, &t->roll, n, loads, -1, NULL);
}

/* The feet's contacts (FootContacts.read): touch codes, contact points, normal loads. */
static void feet(const mjModel *m, const mjData *d, const twin_t *t, double *s)
{
    double f[6];
    for (int i = 0; i < 4; i++) s[S_TOUCH + i] = s[S_FOOT_LOAD + i] = 0.0;
    for (int k = 0; k < d->ncon; k++) {
        const mjContact *c = d->contact + k;
        if (c->geom[0] < 0 || c->geom[1] < 0) continue;  /* a flex's contact: the twin has none */
        int a = t->foot_of[c->geom[0]], b = t->foot_of[c->geom[1]];
        if (a < 0 && b < 0) continue;
        mj_contactForce(m, d, k, f);
        int order[2] = {a < b ? a : b, a < b ? b : a}, n = a == b ? 1 : 2;  /* a foot on a foot: both */
        double code = (c->geom[0] == t->deck_geom || c->geom[1] == t->deck_geom) ? 1.0 : 2.0;
        for (int j = 0; j < n; j++) {
            int i = order[j];
            if (i < 0) continue;
            s[S_TOUCH + i] = code;
            for (int x = 0; x < 3; x++) s[S_POINTS + 4 * x + i] = c->pos[x];
            s[S_FOOT_LOAD + i] += f[0];
        }
    }
}

/* The geoms on the floor that are not planned there (sim.contacts.stray_on_floor), each once, into
 * ids (N_STRAY) and their count into *count; more than N_STRAY: the count N_STRAY + 1 (the caller
 * reads them from the contacts). */
static void stray(const mjData *d, int floor, const unsigned char *planned, double *count, double *ids)
{
    int n = 0;
    for (int k = 0; k < d->ncon; k++) {
        int g1 = d->contact[k].geom[0], g2 = d->contact[k].geom[1];
        if (g1 < 0 || g2 < 0 || (g1 != floor && g2 != floor)) continue;
        int other = g1 == floor ? g2 : g1, seen = 0;
        if (planned[other]) continue;
        for (int j = 0; j < n && j < N_STRAY; j++) seen |= ids[j] == other;
        if (seen) continue;
        if (n < N_STRAY) ids[n] = other;
        n += n <= N_STRAY;
    }
    *count = n;
}

/* The twin now (TwinPlant.state) into s (S_N): the contact forces those of the last step. */
void twin_state(const mjModel *m, mjData *d, const twin_t *t, double *s)
{
    double v6[6];
    s[S_T] = d->time;
    for (int i = 0; i < 3; i++) {
        s[S_TRUNK_POS + i] = d->qpos[t->trunk_q + i];
        s[S_TRUNK_V + i] = d->qvel[t->trunk_v + i];
        s[S_TRUNK_W + i] = d->qvel[t->trunk_v + 3 + i];
        s[S_DECK_POS + i] = d->xpos[3 * t->deck + i];
        s[S_DECK_V + i] = d->qvel[t->deck_v + i];
    }
    memcpy(s + S_TRUNK_R, d->xmat + 9 * t->trunk, 9 * sizeof(double));
    memcpy(s + S_DECK_R, d->xmat + 9 * t->deck, 9 * sizeof(double));
    const double *R = s + S_DECK_R, *w = d->qvel + t->deck_v + 3;
    for (int i = 0; i < 3; i++) s[S_DECK_W + i] = R[3 * i] * w[0] + R[3 * i + 1] * w[1] + R[3 * i + 2] * w[2];
    for (int i = 0; i < 12; i++) {
        s[S_Q + i] = d->qpos[t->qadr[i]];
        s[S_QD + i] = d->qvel[t->dadr[i]];
    }
    for (int j = 0; j < 4; j++) {
        mj_objectVelocity(m, d, mjOBJ_GEOM, t->feet[j], v6, 0);
        for (int x = 0; x < 3; x++) {
            double centre = d->geom_xpos[3 * t->feet[j] + x];
            s[S_CENTRES + 4 * x + j] = centre;
            s[S_FOOT_V + 4 * x + j] = v6[3 + x];
            s[S_SPINS + 4 * x + j] = v6[x];
            s[S_POINTS + 4 * x + j] = centre - (x == 2 ? t->foot_radius : 0.0);
        }
    }
    wheel_forces(m, d, &t->roll, s + S_WHEEL_LOAD, s + S_WHEEL_FORCE);
    feet(m, d, t, s);
    stray(d, t->roll.floor, t->planned, s + S_N_STRAY, s + S_STRAY);
    mj_subtreeVel(m, d);
    for (int i = 0; i < 3; i++) s[S_SYSTEM_V + i] = d->subtree_linvel[i];
}

/* The humanoid twin's tables (skatelib.sim.native's HumanoidTables). */
typedef struct {
    int root, deck, floor, n_act;
    int feet[2], soles[2];    /* the soles' bodies and box geoms, right then left */
    double half_sole;         /* half the sole's thickness */
    const int *act;           /* n_act joint actuators */
    const unsigned char *on_floor;  /* ngeom: planned on the floor (the soles, the wheels) */
} hum_t;

/* The humanoid's truth layout (skatelib.sim.native's H_ offsets); the torques after H_N. */
enum {
    H_T = 0, H_COM = 1, H_COM_V = 4, H_BASE_POS = 7, H_BASE_R = 10, H_FORCE = 19, H_SOLE_ZMP = 25, H_ZMP = 29,
    H_SOLE_POS = 31, H_YAW = 37, H_SOLE_V = 39, H_WZ = 45, H_DECK_POS = 47, H_DECK_R = 50, H_DECK_V = 59,
    H_N_STRAY = 62, H_STRAY = 63, H_N = 71
};

/* The centre of pressure on the plane at height z of a force f with the moment tau about c (_cop). */
static void cop(const double *f, const double *tau, const double *c, double z, double *out)
{
    double h = z - c[2];
    out[0] = c[0] + (h * f[0] - tau[1]) / f[2];
    out[1] = c[1] + (tau[0] + h * f[1]) / f[2];
}

/* What happened (HumanoidPlant.truth) into s (H_N + n_act): the soles' wrenches from their feet's
 * cfrc_ext (a torque about the robot's COM and a force), the joint ZMP on the plane at plane_z. */
void humanoid_truth(const mjModel *m, mjData *d, const hum_t *h, double plane_z, double *s)
{
    double w[6], tau[2][3], total_f[3], total_tau[3];
    const double *c = d->subtree_com + 3 * h->root;
    s[H_T] = d->time;
    for (int j = 0; j < 2; j++) {
        const double *ext = d->cfrc_ext + 6 * h->feet[j];
        for (int x = 0; x < 3; x++) {
            tau[j][x] = ext[x];
            s[H_FORCE + 3 * j + x] = ext[3 + x];
            s[H_SOLE_POS + 3 * j + x] = d->geom_xpos[3 * h->soles[j] + x];
        }
    }
    const double *force = s + H_FORCE;
    for (int j = 0; j < 2; j++) {
        if (force[3 * j + 2] > 1.0)
            cop(force + 3 * j, tau[j], c, s[H_SOLE_POS + 3 * j + 2] - h->half_sole, s + H_SOLE_ZMP + 2 * j);
        else
            s[H_SOLE_ZMP + 2 * j] = s[H_SOLE_ZMP + 2 * j + 1] = NAN;
    }
    for (int x = 0; x < 3; x++) {
        total_f[x] = force[x] + force[3 + x];
        total_tau[x] = tau[0][x] + tau[1][x];
    }
    if (total_f[2] > 1.0)
        cop(total_f, total_tau, c, plane_z, s + H_ZMP);
    else
        s[H_ZMP] = s[H_ZMP + 1] = NAN;
    for (int j = 0; j < 2; j++) {
        const double *R = d->geom_xmat + 9 * h->soles[j];
        s[H_YAW + j] = atan2(R[3], R[0]);
        mj_objectVelocity(m, d, mjOBJ_GEOM, h->soles[j], w, 0);
        for (int x = 0; x < 3; x++) s[H_SOLE_V + 3 * j + x] = w[3 + x];
        s[H_WZ + j] = w[2];
    }
    mj_subtreeVel(m, d);
    for (int x = 0; x < 3; x++) {
        s[H_COM + x] = c[x];
        s[H_COM_V + x] = d->subtree_linvel[3 * h->root + x];
        s[H_BASE_POS + x] = d->xpos[3 * h->root + x];
    }
    memcpy(s + H_BASE_R, d->xmat + 9 * h->root, 9 * sizeof(double));
    if (h->deck >= 0) {
        mj_objectVelocity(m, d, mjOBJ_BODY, h->deck, w, 0);
        for (int x = 0; x < 3; x++) {
            s[H_DECK_POS + x] = d->xpos[3 * h->deck + x];
            s[H_DECK_V + x] = w[3 + x];
        }
        memcpy(s + H_DECK_R, d->xmat + 9 * h->deck, 9 * sizeof(double));
    }
    stray(d, h->floor, h->on_floor, s + H_N_STRAY, s + H_STRAY);
    for (int i = 0; i < h->n_act; i++) s[H_N + i] = d->actuator_force[h->act[i]];
}

/* The humanoid's sensors (HumanoidPlant.readings) into out (n): out[i] the kind[i] source's
 * element idx[i] (0: sensordata, 1: minus sensordata, 2: qpos, 3: qvel) plus noise[i]; then
 * out[0..3], the IMU's quaternion, made unit. */
void humanoid_sense(const mjData *d, int n, const int *kind, const int *idx, const double *noise, double *out)
{
    for (int i = 0; i < n; i++) {
        double v = kind[i] <= 1 ? d->sensordata[idx[i]] : kind[i] == 2 ? d->qpos[idx[i]] : d->qvel[idx[i]];
        out[i] = (kind[i] == 1 ? -v : v) + noise[i];
    }
    double norm = sqrt(out[0] * out[0] + out[1] * out[1] + out[2] * out[2] + out[3] * out[3]);
    for (int i = 0; i < 4; i++) out[i] = out[i] / norm;
}
