/* The virtual-fixture step in C (see sbs_ctrl2_fixture.h): monitor.check_inputs,
   monitor.check_motion, the generated controller, monitor.check_command and the fallback
   k = 0, with the arithmetic of fixture.VirtualFixture.step and the reason it reports (the
   first check that fails in its order). The planes' part of check_inputs and check_command
   run in one pass after the controller, which computes each plane's distance once. Every
   expression is written in the Python's evaluation order (left to right), so the monitor's
   decisions agree with the Python kernel except within a rounding of its thresholds (numpy
   may sum the dot products n.f in another order). */
#include <math.h>

#include "sbs_ctrl2_fixture.h"

/* np.minimum: NaN wins (so a NaN distance passes `worst < -tol` exactly as in Python) */
static double min_keep_nan(double a, double b)
{
    if (isnan(a) || isnan(b))
        return NAN;
    return a < b ? a : b;
}

static int finite3(const double v[3])
{
    return isfinite(v[0]) && isfinite(v[1]) && isfinite(v[2]);
}

static double distance(const double p[3], const double *rx, const double *ry, const double *rz,
                       const double *nx, const double *ny, const double *nz, size_t i)
{
    return (p[0] - rx[i]) * nx[i] + (p[1] - ry[i]) * ny[i] + (p[2] - rz[i]) * nz[i];
}

static int check_scalars(const double p[3], const double f[3], const double fp[3], double G, double D, double e)
{
    if (!finite3(p) || !finite3(f) || !finite3(fp))
        return SBS_CTRL2_INPUT_NOT_FINITE;
    if (!(isfinite(G) && G > 0) || !(isfinite(D) && D > 0) || !(isfinite(e) && e > 0))
        return SBS_CTRL2_PARAMETER;
    return SBS_CTRL2_OK;
}

static int check_motion(const sbs_ctrl2_memory *m, const double p[3], double G, double dt, double tolerance)
{
    double error = 0.0;
    int a;
    if (!m->has_previous)
        return SBS_CTRL2_OK;
    for (a = 0; a < 3; a++) {
        double predicted = m->p[a] + G * m->k * (m->f[a] * dt + m->fp[a] * dt * dt / 2);
        double gap = fabs(p[a] - predicted);
        if (isnan(gap) || gap > error)
            error = gap; /* np.max keeps a NaN */
    }
    return error > tolerance ? SBS_CTRL2_MOTION : SBS_CTRL2_OK;
}

/* monitor.check_command's test on one plane: 1 where the gain k fails it (the lowest point of
   the step's path is past the plane by more than the tolerance) */
static int command_fails(double k, double d0, double fn, double fnp, double G, double e)
{
    double at_end = d0 + G * k * (fn * e + fnp * e * e / 2);
    double lowest = min_keep_nan(d0, at_end);
    /* the vertex -fn/fnp is > 0 only where fnp > 0 and fn < 0 (else it is <= 0 or NaN) */
    if (fnp > 0 && fn < 0) {
        double vertex_t = -fn / fnp;
        if (vertex_t > 0 && vertex_t < e)
            lowest = min_keep_nan(lowest, d0 + G * k * (fn * vertex_t + fnp * (vertex_t * vertex_t) / 2));
    }
    /* the tolerance is >= 0 (or NaN): a lowest point >= 0 passes without it */
    if (!(lowest >= 0)) {
        double tol = SBS_CTRL2_RELATIVE_TOLERANCE * (1 + fabs(d0) + G * fabs(fn) * e + G * fabs(fnp) * e * e);
        if (lowest < -tol)
            return 1;
    }
    return 0;
}

/* monitor.check_inputs on the planes and, where `command` (the gain k in [0, 1] to check),
   monitor.check_command, in one pass that computes each plane's distance d0 once. Returns the
   planes' verdict (the reason the Python reports: its checks run one after the other over
   every plane -- non-finite planes first, then lengths, then distances); *command_failed: 1
   where a plane fails the command check (which counts only if the planes pass). */
static int check_planes(const double p[3], const double f[3], const double fp[3],
                        const double *rx, const double *ry, const double *rz,
                        const double *nx, const double *ny, const double *nz, size_t n,
                        double G, double e, int command, double k, int *command_failed)
{
    size_t i;
    int worst = SBS_CTRL2_OK, failed = 0;
    for (i = 0; i < n; i++) {
        double length2 = nx[i] * nx[i] + ny[i] * ny[i] + nz[i] * nz[i];
        double d0 = distance(p, rx, ry, rz, nx, ny, nz, i);
        /* a non-finite point or normal makes d0 or length2 non-finite (inf * 0 is NaN), so the
           six tests run only where one of the two is not finite (it may also have overflowed) */
        if (!(isfinite(d0) && isfinite(length2))
            && !(isfinite(rx[i]) && isfinite(ry[i]) && isfinite(rz[i]) && isfinite(nx[i]) && isfinite(ny[i])
                 && isfinite(nz[i])))
            return SBS_CTRL2_PLANE_NOT_FINITE;
        if (fabs(length2 - 1.0) > SBS_CTRL2_UNIT_TOLERANCE)
            worst = SBS_CTRL2_NORMAL_NOT_UNIT; /* outranks a distance */
        if (d0 < 0 && d0 < -SBS_CTRL2_RELATIVE_TOLERANCE * (1 + fabs(d0)))
            worst = worst == SBS_CTRL2_OK ? SBS_CTRL2_PAST_BOUNDARY : worst;
        if (command && !failed) {
            double fn = nx[i] * f[0] + ny[i] * f[1] + nz[i] * f[2];
            double fnp = nx[i] * fp[0] + ny[i] * fp[1] + nz[i] * fp[2];
            failed = command_fails(k, d0, fn, fnp, G, e);
        }
    }
    *command_failed = failed;
    return worst;
}

static int fall_back(int reason, const double p[3], sbs_ctrl2_memory *memory, double *k)
{
    int a;
    memory->has_previous = finite3(p);
    for (a = 0; a < 3; a++) {
        memory->p[a] = p[a];
        memory->f[a] = memory->fp[a] = 0.0;
    }
    memory->k = 0.0;
    *k = 0.0; /* the tool stops where it is, which no boundary can object to */
    return reason;
}

int sbs_ctrl2_fixture_step(const double p[3], const double f[3], const double fp[3],
                           const double *rx, const double *ry, const double *rz,
                           const double *nx, const double *ny, const double *nz, size_t n,
                           double G, double D, double e, double dt, double position_tolerance,
                           sbs_ctrl2_memory *memory, double *k)
{
    double gain = NAN;
    int a, enabled = 0, motion, planes, command, command_failed;
    int verdict = check_scalars(p, f, fp, G, D, e);
    if (verdict != SBS_CTRL2_OK)
        return fall_back(verdict, p, memory, k);
    /* The planes' checks and the command's share one pass after the controller (which
       decides nothing here until the planes pass); the verdict is the Python's, in its order:
       the inputs (scalars, then planes), the motion, the controller, the command. */
    motion = check_motion(memory, p, G, dt, position_tolerance);
    if (motion == SBS_CTRL2_OK) {
        enabled = sbs_ctrl2_controller(p[0], p[1], p[2], fp[0], fp[1], fp[2], f[0], f[1], f[2], D, e, G,
                                       rx, nx, ry, ny, rz, nz, n, &gain);
        if (-SBS_CTRL2_ROUNDING <= gain && gain < 0)
            gain = 0.0; /* -d0*tmp for a tool on a plane up to rounding: a lower gain is always allowed */
    }
    /* check_command: the gain finite and in [0, 1], then safe for the step on every plane */
    command = motion == SBS_CTRL2_OK && enabled > 0 && isfinite(gain) && 0.0 <= gain && gain <= 1.0;
    planes = check_planes(p, f, fp, rx, ry, rz, nx, ny, nz, n, G, e, command, gain, &command_failed);
    if (planes != SBS_CTRL2_OK)
        return fall_back(planes, p, memory, k);
    if (motion != SBS_CTRL2_OK)
        return fall_back(motion, p, memory, k);
    if (enabled < 0)
        return fall_back(SBS_CTRL2_UNDECIDED, p, memory, k);
    if (!enabled)
        return fall_back(SBS_CTRL2_NO_RUN, p, memory, k);
    if (!command || command_failed)
        return fall_back(SBS_CTRL2_COMMAND, p, memory, k);
    memory->has_previous = 1;
    for (a = 0; a < 3; a++) {
        memory->p[a] = p[a];
        memory->f[a] = f[a];
        memory->fp[a] = fp[a];
    }
    memory->k = gain;
    *k = gain;
    return SBS_CTRL2_OK;
}
