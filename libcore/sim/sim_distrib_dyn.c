/* Dynamics with each MPI rank assembling its own elements (sim_distrib.h,
 * pf_sim_distrib_dynamics): sim.c's semi-implicit Euler on a part,
 *     ((1 + h alpha) M + (h beta + h^2) (K + C)) v' = M v + h (f + f_c - K u),     u' = u + h v',
 * C and f_c the penalty contact's stiffness and forces (contact.c) at the mesh's boundary nodes,
 * each rank testing the points of its own elements or nodes (sim_distrib_contact.c).
 *
 * DG:
 * Each rank keeps the state of its part: its own elements and the halo (their face neighbours),
 * a halo element's state a copy of what its owner holds. The corotated stiffness of the part at u
 * (sim_dg.c: each element's rotation from its own coefficients, DG paper sec. 6.1, a face's terms
 * warped with its two elements' rotations, which the part has) holds the owned elements' rows of
 * K whole, and M is block diagonal, so the right-hand side's owned rows are computed on the part.
 * The system matrix goes to PETSc as the COO entries this rank sends (sim_distrib.c), solved by CG
 * + GAMG with the rigid modes, from the velocity extrapolated as sim.c does. One scatter gives
 * each rank v' at all its part's unknowns, and u' = u + h v' follows there by the owner's
 * arithmetic, so the halo's copies stay exact. sim.c's checks, as reductions over the owned
 * elements: a non-finite or absurd state after each step, and at each frame's end the kinetic
 * energy against what the body had and was given.
 *
 * CG: a part is its own elements, whose nodes on the cuts other parts hold too (sim_distrib_cg.c).
 * Every term of a step is a sum over elements (M v, f, K u, the warping forces; an element's
 * rotation from its own nodes), so each rank computes its elements' share at all of its part's
 * nodes and PETSc sums the shares (ADD_VALUES), as for the matrix; the kinetic energy and the
 * forces' work are sums over elements too. The scatter gives each rank v' at all of its nodes. */
#include "sim_distrib.h"

#include <math.h>
#include <string.h>

#include "sim_internal.h"

#ifdef PF_HAVE_PETSC

#include "../solve/solve_petsc.h"

/* A rank's dynamic state: per unknown of the part [n_dofs] (u is p->u). */
typedef struct dyn {
    part *p;
    pf_contact *contact; /* NULL without ground and obstacles, or elements */
    pf_contact_part contact_part;
    int64_t contacts;     /* found by this step's detection on this rank */
    int64_t all_contacts; /* and by all its steps' */
    double *f_ext, *v, *f, *rhs, *ku, *v_old, *dv, *dv2, *masked;
    Mat a;
    Vec x, b, local; /* local wraps v */
    VecScatter take; /* x to every unknown of the part */
    KSP ksp;
    PetscInt start; /* the first row this rank owns */
    int trend;      /* velocity differences known, up to 2 */
    bool assembled;
    double time, work, kinetic, kinetic0, fixed_energy, energy_floor, model_size;
    int64_t steps;
} dyn;

static pf_status allocate(dyn *d, pf_error *err)
{
    size_t n = (size_t)d->p->n_dofs + 1;
    double **vectors[] = {&d->f_ext, &d->v,  &d->f,   &d->rhs,   &d->ku,
                          &d->v_old, &d->dv, &d->dv2, &d->masked};
    for (size_t k = 0; k < sizeof vectors / sizeof *vectors; ++k) {
        *vectors[k] = pf_calloc(n, sizeof(double));
        PF_CHECK(*vectors[k], err, PF_ERR_NOMEM, "cannot allocate %zu unknowns", n - 1);
    }
    return PF_OK;
}

/* The matrix (the part's stiffness at rest as its first values), its vectors, the rigid modes,
 * the KSP and the scatter to the part's unknowns. */
static pf_status create_solver(dyn *d, pf_error *err)
{
    part *p = d->p;
    PF_TRY(pf_sim_distrib_matrix(p, &d->a, err));
    PF_PETSC_TRY(MatCreateVecs(d->a, &d->x, &d->b));
    PF_PETSC_TRY(VecGetOwnershipRange(d->x, &d->start, NULL));
    PF_TRY(pf_sim_distrib_rigid_modes(p, d->a, err));
    PF_TRY(pf_petsc_create_ksp(d->a, p->scene.solver.tolerance, &d->ksp, err));
    IS rows;
    PF_PETSC_TRY(
        ISCreateGeneral(PETSC_COMM_SELF, (PetscInt)p->n_dofs, p->row, PETSC_USE_POINTER, &rows));
    PF_PETSC_TRY(VecCreateSeqWithArray(PETSC_COMM_SELF, 1, (PetscInt)p->n_dofs, d->v, &d->local));
    PetscErrorCode pe = VecScatterCreate(d->x, rows, d->local, NULL, &d->take);
    ISDestroy(&rows);
    PF_PETSC_TRY(pe);
    return PF_OK;
}

static void destroy(dyn *d)
{
    pf_contact_destroy(&d->contact);
    KSPDestroy(&d->ksp), MatDestroy(&d->a), VecDestroy(&d->x), VecDestroy(&d->b);
    VecScatterDestroy(&d->take), VecDestroy(&d->local);
    double *vectors[] = {d->f_ext, d->v, d->f, d->rhs, d->ku, d->v_old, d->dv, d->dv2, d->masked};
    for (size_t k = 0; k < sizeof vectors / sizeof *vectors; ++k)
        pf_free(vectors[k]);
}

/* dst's rows (this rank's) from the owned unknowns of src [n_dofs], plus add [n_dofs] (NULL:
 * none). */
static pf_status owned_rows(const dyn *d, const double *src, const double *add, Vec dst,
                            pf_error *err)
{
    const part *p = d->p;
    PetscScalar *a;
    PF_PETSC_TRY(VecGetArray(dst, &a));
    for (int64_t i = 0; i < p->n_dofs; ++i)
        if (p->row_owned[i])
            a[p->row[i] - d->start] = src[i] + (add ? add[i] : 0);
    PF_PETSC_TRY(VecRestoreArray(dst, &a));
    return PF_OK;
}

/* Whether unknown i of the part counts in sums over elements on this rank: DG the owned
 * elements', CG all (each element is in one part; shared nodes carry each part's share). */
static bool counts(const dyn *d, int64_t i)
{
    return d->p->scene.method == PF_METHOD_CG || d->p->row_owned[i];
}

/* A right-hand side's rows from src [n_dofs]: DG the owned rows, CG the parts' shares summed. */
static pf_status rhs_rows(const dyn *d, const double *src, Vec dst, pf_error *err)
{
    const part *p = d->p;
    if (p->scene.method != PF_METHOD_CG)
        return owned_rows(d, src, NULL, dst, err);
    PF_PETSC_TRY(VecZeroEntries(dst));
    PF_PETSC_TRY(VecSetValues(dst, (PetscInt)p->n_dofs, p->row, src, ADD_VALUES));
    PF_PETSC_TRY(VecAssemblyBegin(dst));
    PF_PETSC_TRY(VecAssemblyEnd(dst));
    return PF_OK;
}

/* The sum over the ranks of the kinetic energy 1/2 vel^T M vel of the elements each counts. */
static double kinetic_energy(dyn *d, const double *vel)
{
    part *p = d->p;
    double mine = 0, all = 0;
    if (p->method) {
        for (int64_t i = 0; i < p->n_dofs; ++i)
            d->masked[i] = counts(d, i) ? vel[i] : 0;
        pf_vec3 linear, angular;
        p->ops->momentum(p->method, p->u, d->masked, &mine, &linear, &angular);
    }
    MPI_Allreduce(&mine, &all, 1, MPI_DOUBLE, MPI_SUM, PETSC_COMM_WORLD);
    return all;
}

/* sim.c's start_energy and initial_energy: the kinetic energy at the start, its floor (1e-12 of
 * the body moving its own size in a time step), and the elastic energy 1/2 f^T K^-1 f that
 * prescribed displacements with the constant loads release (the state starts at rest and
 * undeformed, so 1/2 u^T K u is 0). Collective. */
static pf_status start_energy(dyn *d, pf_error *err)
{
    part *p = d->p;
    const pf_scene *sc = &p->scene;
    d->kinetic0 = kinetic_energy(d, d->v);
    double zero[9] = {0}, b[3] = {d->model_size / sc->dt, 0, 0};
    if (p->method)
        p->ops->affine(p->method, zero, b, d->rhs);
    d->energy_floor = 1e-12 * kinetic_energy(d, d->rhs);
    bool moves = false;
    for (int32_t k = 0; k < sc->n_fixed; ++k)
        moves |= pf_v3_max_abs(sc->fixed[k].displacement) > 0;
    if (!moves)
        return PF_OK;
    if (p->method) {
        memcpy(d->f, d->f_ext, (size_t)p->n_dofs * sizeof *d->f);
        p->ops->stiffness(p->method, p->u, false, &p->k, d->f);
    }
    PF_TRY(pf_sim_distrib_matrix_values(p, d->a, err));
    PF_TRY(rhs_rows(d, d->f, d->b, err));
    PF_PETSC_TRY(VecZeroEntries(d->x));
    PF_PETSC_TRY(KSPSolve(d->ksp, d->b, d->x));
    PetscScalar e = 0;
    PF_PETSC_TRY(VecDot(d->b, d->x, &e));
    d->fixed_energy = fabs(0.5 * e);
    return PF_OK;
}

/* The system of a step of length h at the state (sim.c, step): rhs = M v + h (f - K u) and the
 * matrix's values when they changed. */
static pf_status assemble(dyn *d, double h, pf_error *err)
{
    part *p = d->p;
    const pf_scene *sc = &p->scene;
    size_t n = (size_t)p->n_dofs;
    d->contacts = d->contact ? pf_contact_detect(d->contact, d->time + h, p->u, d->v, h) : 0;
    d->all_contacts += d->contacts;
    if (p->method) {
        /* DG: the part's owned rows of K u are K's */
        double kscale = h * sc->damping_beta + h * h, mscale = 1 + h * sc->damping_alpha;
        memcpy(d->f, d->f_ext, n * sizeof *d->f);
        pf_method_step_begin(p->ops, p->method, p->u, d->v, sc->corotation, kscale, mscale, &p->k,
                             d->f, d->ku, n);
        if (d->contacts > 0)
            pf_contact_forces(d->contact, p->u, d->f);
        pf_method_step_finish(p->ops, p->method, p->u, d->v, h, kscale, mscale, &p->k, d->f,
                              d->ku, d->rhs, n);
        if (d->contacts > 0)
            pf_contact_add_stiffness(d->contact, kscale, &p->k);
    }
    /* contacts on any rank, and whether any rank's set changed (sim.c: an impact or a release
     * breaks the velocity's trend) */
    int mine[2] = {d->contacts > 0, d->contact && pf_contact_set_changed(d->contact)};
    int any[2] = {0, 0};
    if (pf_scene_has_contact(sc))
        MPI_Allreduce(mine, any, 2, MPI_INT, MPI_MAX, PETSC_COMM_WORLD);
    if (any[1])
        d->trend = 0;
    /* without corotation or contact the matrix stays, and so does GAMG's hierarchy */
    if (!d->assembled || sc->corotation || any[0] || any[1])
        PF_TRY(pf_sim_distrib_matrix_values(p, d->a, err));
    d->assembled = true;
    return rhs_rows(d, d->rhs, d->b, err);
}

/* v' from the velocity extrapolated through the last steps' (sim.c: v + 2 dv - dv2, linear or
 * none when fewer are known), on every rank's part; rs gets the solve's counts. */
static pf_status solve(dyn *d, rank_stats *rs, pf_error *err)
{
    part *p = d->p;
    size_t n = (size_t)p->n_dofs;
    for (size_t q = 0; q < n; ++q) {
        d->v_old[q] = d->v[q];
        d->ku[q] = d->trend == 0 ? 0 : d->trend == 1 ? d->dv[q] : 2 * d->dv[q] - d->dv2[q];
    }
    PF_TRY(owned_rows(d, d->v, d->ku, d->x, err));
    PF_PETSC_TRY(KSPSolve(d->ksp, d->b, d->x));
    KSPConvergedReason reason;
    PetscInt its;
    PetscReal rnorm, bnorm;
    PF_PETSC_TRY(KSPGetConvergedReason(d->ksp, &reason));
    PF_PETSC_TRY(KSPGetIterationNumber(d->ksp, &its));
    PF_PETSC_TRY(KSPGetResidualNorm(d->ksp, &rnorm));
    PF_PETSC_TRY(VecNorm(d->b, NORM_2, &bnorm));
    double relative = bnorm > 0 ? rnorm / bnorm : 0;
    rs->iterations += its;
    rs->residual = fmax(rs->residual, relative);
    PF_CHECK(reason > 0, err, PF_ERR_NUMERIC,
             "PETSc's KSP stopped without converging (reason %d) after %d iterations, residual "
             "%.3g relative to the right-hand side",
             (int)reason, (int)its, relative);
    PF_PETSC_TRY(VecScatterBegin(d->take, d->x, d->local, INSERT_VALUES, SCATTER_FORWARD));
    PF_PETSC_TRY(VecScatterEnd(d->take, d->x, d->local, INSERT_VALUES, SCATTER_FORWARD));
    return PF_OK;
}

/* u' = u + h v', the velocity's trend, and the work of the constant forces over the step. */
static void advance(dyn *d, double h)
{
    part *p = d->p;
    double *older = d->dv2;
    d->dv2 = d->dv;
    d->dv = older;
    double power = 0;
    for (int64_t q = 0; q < p->n_dofs; ++q) {
        p->u[q] += h * d->v[q];
        d->dv[q] = d->v[q] - d->v_old[q];
        if (counts(d, q))
            power += d->f_ext[q] * d->v[q];
    }
    if (d->contacts > 0)
        power += pf_contact_obstacle_power(d->contact);
    d->trend = d->trend < 2 ? d->trend + 1 : 2;
    d->work += h * power; /* this rank's share */
    d->steps++;
}

/* sim.c's state_is_sane and worst_element over every rank's owned unknowns (collective):
 * whether any rank's state is broken (non-finite, or a displacement above 1e3 model sizes), and
 * the element (of the whole mesh) whose unknowns went non-finite, else the one that moved most. */
static int worst_element(const dyn *d, bool *broken)
{
    const part *p = d->p;
    struct {
        double score; /* the largest |u|, infinite for a non-finite u or v */
        int element;
    } mine = {-1, -1}, worst;
    bool bad = false;
    for (int64_t q = 0; q < p->n_dofs; ++q) {
        if (!p->row_owned[q])
            continue;
        double s = isfinite(p->u[q]) && isfinite(d->v[q]) ? fabs(p->u[q]) : INFINITY;
        bad |= !(s <= 1e3 * d->model_size);
        if (s > mine.score)
            mine.score = s, mine.element = p->gelem[p->ops->element_of_dof(p->method, q)];
    }
    int any = 0, mine_bad = bad;
    MPI_Allreduce(&mine_bad, &any, 1, MPI_INT, MPI_MAX, PETSC_COMM_WORLD);
    MPI_Allreduce(&mine, &worst, 1, MPI_DOUBLE_INT, MPI_MAXLOC, PETSC_COMM_WORLD);
    *broken = any;
    return worst.element;
}

/* A step's state (collective): PF_ERR_NUMERIC, as sim.c, when any rank's is broken. */
static pf_status check_state(dyn *d, pf_error *err)
{
    bool broken = false;
    int element = worst_element(d, &broken);
    PF_CHECK(!broken, err, PF_ERR_NUMERIC, "the simulation diverged (element %d first)", element);
    return PF_OK;
}

/* sim.c's energy_is_bounded at a frame's end (collective). */
static pf_status check_energy(dyn *d, pf_error *err)
{
    double work = 0;
    MPI_Allreduce(&d->work, &work, 1, MPI_DOUBLE, MPI_SUM, PETSC_COMM_WORLD);
    d->kinetic = kinetic_energy(d, d->v);
    double bound = d->kinetic0 + fmax(work, 0) + d->fixed_energy;
    if (d->kinetic <= 4 * bound + d->energy_floor)
        return PF_OK;
    bool broken;
    int element = worst_element(d, &broken);
    return pf_error_set(err, PF_ERR_NUMERIC, __FILE__, __LINE__,
                        "the simulation diverged: kinetic energy %.3g exceeds four times what the "
                        "body had and was given (%.3g), element %d moved most; a larger penalty "
                        "(DG), a smaller time step or more damping may help",
                        d->kinetic, bound, element);
}

/* One frame's substeps (collective; every rank fails alike). */
static pf_status frame(dyn *d, int32_t index, rank_stats *rs, pf_error *err)
{
    const pf_scene *sc = &d->p->scene;
    double h = sc->dt / sc->substeps;
    for (int32_t k = 0; k < sc->substeps; ++k) {
        double cpu0 = pf_cpu_seconds();
        pf_status st = assemble(d, h, err);
        double cpu1 = pf_cpu_seconds();
        rs->assembly_cpu += cpu1 - cpu0;
        if (st >= 0)
            st = solve(d, rs, err);
        rs->solve_cpu += pf_cpu_seconds() - cpu1;
        if (st >= 0) {
            advance(d, h);
            st = check_state(d, err);
        }
        if (st >= 0 && k + 1 == sc->substeps)
            st = check_energy(d, err);
        if (st < 0) {
            pf_error_prefix(err, "frame %d, step %d", (int)index, (int)k + 1);
            return st;
        }
        d->time += h;
    }
    return PF_OK;
}

/* Frame index's outputs to rank 0 and its frame function (collective). */
static pf_status emit(dyn *d, const distrib_out *o, int32_t index, pf_error *err)
{
    long long contacts = 0, mine = d->all_contacts;
    MPI_Reduce(&mine, &contacts, 1, MPI_LONG_LONG, MPI_SUM, 0, PETSC_COMM_WORLD);
    if (o) {
        o->res->contacts = contacts;
        o->res->frame = index;
        o->res->time = d->time;
        o->res->steps = d->steps;
        o->res->kinetic = d->kinetic;
    }
    return pf_sim_distrib_agree(pf_sim_distrib_outputs(d->p, o, err), err);
}

/* The checkpoint after frame index, when due (collective): sim.c's state; a restart point, after
 * which the velocity's trend is forgotten, as a run restored from it starts. At frame 0 the
 * energy check has not started on one process: its sums are stored as zero, and a run restored
 * there starts them afresh. */
static pf_status checkpoint(dyn *d, const distrib_out *o, int32_t index, const rank_stats *rs,
                            pf_error *err)
{
    if (!pf_sim_distrib_checkpoint_due(d->p, index))
        return PF_OK;
    pf_sim_saved st = {.frame = index, .time = d->time};
    if (index > 0)
        st = (pf_sim_saved){.frame = index,
                            .time = d->time,
                            .energy_started = true,
                            .kinetic0 = d->kinetic0,
                            .work = d->work,
                            .fixed_energy = d->fixed_energy,
                            .energy_floor = d->energy_floor};
    d->trend = 0;
    return pf_sim_distrib_checkpoint(d->p, d->v, &st, rs, o, err);
}

/* The state at the start: at rest with the energy check's sums, or a checkpoint's (collective);
 * *first the frame it is of. */
static pf_status initial_state(dyn *d, const distrib_out *o, int32_t *first, pf_error *err)
{
    *first = 0;
    if (!d->p->h.restoring)
        return pf_sim_distrib_agree(start_energy(d, err), err);
    pf_sim_saved st;
    PF_TRY(pf_sim_distrib_resume(d->p, d->v, &st, o, err));
    *first = st.frame;
    d->time = st.time;
    if (!st.energy_started)
        return pf_sim_distrib_agree(start_energy(d, err), err);
    d->kinetic0 = st.kinetic0, d->work = st.work, d->fixed_energy = st.fixed_energy;
    d->energy_floor = st.energy_floor;
    d->kinetic = kinetic_energy(d, d->v);
    return PF_OK;
}

pf_status pf_sim_distrib_dynamics(part *p, const distrib_out *o, rank_stats *rs, double cpu0,
                                  pf_error *err)
{
    dyn d = {.p = p};
    d.model_size = sqrt(pow(p->h.hi[0] - p->h.lo[0], 2) + pow(p->h.hi[1] - p->h.lo[1], 2) +
                        pow(p->h.hi[2] - p->h.lo[2], 2));
    pf_status st = pf_sim_distrib_agree(allocate(&d, err), err);
    if (st >= 0 && p->method)
        p->ops->external_forces(p->method, d.f_ext);
    if (st >= 0)
        st = pf_sim_distrib_agree(create_solver(&d, err), err);
    if (st >= 0)
        st = pf_sim_distrib_agree(
            pf_sim_distrib_contact_create(p, d.model_size, &d.contact_part, &d.contact, err), err);
    int32_t first = 0;
    if (st >= 0)
        st = initial_state(&d, o, &first, err);
    rs->setup_cpu = pf_cpu_seconds() - cpu0;
    if (st >= 0 && !p->h.restoring)
        st = emit(&d, o, 0, err);
    if (st >= 0 && !p->h.restoring)
        st = checkpoint(&d, o, 0, rs, err);
    for (int32_t k = first + 1; st >= 0 && k <= p->scene.frames; ++k) {
        st = frame(&d, k, rs, err);
        if (st >= 0)
            st = emit(&d, o, k, err);
        if (st >= 0)
            st = checkpoint(&d, o, k, rs, err);
    }
    destroy(&d);
    return st;
}

#endif
