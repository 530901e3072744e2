/* Cheap calls into the virtual-fixture step: see sbs_ctrl2_fixture_calls.h. */
#include "sbs_ctrl2_fixture_calls.h"

static int step_context(sbs_ctrl2_fixture_context *c, const double p[3], const double f[3], const double fp[3],
                        double dt)
{
    c->before = c->memory;
    return sbs_ctrl2_fixture_step(p, f, fp, c->rx, c->ry, c->rz, c->nx, c->ny, c->nz, c->n, c->G, c->D, c->e, dt,
                                  c->position_tolerance, &c->memory, &c->k);
}

int sbs_ctrl2_fixture_step_values(sbs_ctrl2_fixture_context *c, double px, double py, double pz, double fx,
                                  double fy, double fz, double fpx, double fpy, double fpz, double dt)
{
    const double p[3] = {px, py, pz}, f[3] = {fx, fy, fz}, fp[3] = {fpx, fpy, fpz};
    return step_context(c, p, f, fp, dt);
}

size_t sbs_ctrl2_fixture_step_many(sbs_ctrl2_fixture_context *c, const double *inputs, size_t rows,
                                   const double *dt, size_t dt_stride, double *k, int *reason)
{
    size_t i;
    for (i = 0; i < rows; i++) {
        const double *row = inputs + 9 * i;
        *reason = step_context(c, row, row + 3, row + 6, dt[i * dt_stride]);
        if (*reason != SBS_CTRL2_OK)
            return i;
        k[i] = c->k;
    }
    *reason = SBS_CTRL2_OK;
    return rows;
}
