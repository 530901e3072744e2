/* Cheap calls into the virtual-fixture step (sbs_ctrl2_fixture.h) for a caller that pays per
   argument (Python through cffi): the planes, parameters and memory sit in one context the
   caller fills once, the inputs come by value, and `step_many` runs a whole sequence of
   periods in one call. Same step, same memory, same verdicts as sbs_ctrl2_fixture_step.

   C99, no allocation, no globals. */
#ifndef CERTILOOP_SBS_CTRL2_FIXTURE_CALLS_H
#define CERTILOOP_SBS_CTRL2_FIXTURE_CALLS_H

#include <stddef.h>

#include "sbs_ctrl2_fixture.h"

typedef struct {
    const double *rx, *ry, *rz, *nx, *ny, *nz; /* the planes, n elements each (owned by the caller) */
    size_t n;
    double G, D, e, position_tolerance;
    sbs_ctrl2_memory memory;  /* the step's memory after the last step */
    sbs_ctrl2_memory before;  /* the memory before the last step (for a caller that redoes it) */
    double k;                 /* the last step's gain */
} sbs_ctrl2_fixture_context;

/* sbs_ctrl2_fixture_step on the context's planes, parameters and memory, with p = (px, py, pz),
   f = (fx, fy, fz), fp = (fpx, fpy, fpz); the gain in c->k. */
int sbs_ctrl2_fixture_step_values(sbs_ctrl2_fixture_context *c, double px, double py, double pz, double fx,
                                  double fy, double fz, double fpx, double fpy, double fpz, double dt);

/* Steps through `rows` periods, row i of `inputs` being p, f, fp (9 doubles) and its time since
   the previous step dt[i * dt_stride] (stride 0: one dt for all), writing each gain to k[i].
   Stops at the first step that does not pass (its memory before it in c->before, its reason
   in *reason) and returns the number of rows that passed (rows: all passed, *reason = OK). */
size_t sbs_ctrl2_fixture_step_many(sbs_ctrl2_fixture_context *c, const double *inputs, size_t rows,
                                   const double *dt, size_t dt_stride, double *k, int *reason);

#endif
