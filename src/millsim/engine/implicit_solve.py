"""The driver of the implicit lubrication solve (:mod:`millsim.engine.implicit`): conjugate
gradients over the block passes of the implicit scheme, run by the step loop once per kick
(:mod:`millsim.engine.loop`)."""

import numpy as np
from numba import njit, prange

from .implicit import RW_LAM, RW_Z
from .models import stable_identity


def _block_passes(lub_blocks, parallel):
    """The solve's passes over the blocks (engine.implicit's block kernels), one parallel loop per
    function: each pass reads what the one before wrote for other blocks, so they must not be
    fused. Returns (setup_particle_pass, setup_slot_pass, restart_pass, pass1_own, pass1_partner,
    pass3)."""
    setup_particles, p1_own, p1_partner, setup_slots, restart, p3 = lub_blocks

    def setup_particle_pass(n_blocks, back, tau, P, R, S):
        for blk in prange(n_blocks):
            setup_particles(np.int64(blk), back, tau, P, R, S)

    def setup_slot_pass(n_blocks, back, tau, warm, P, C, S):
        for blk in prange(n_blocks):
            setup_slots(np.int64(blk), back, tau, warm, P, C, S)

    def restart_pass(n_blocks, P, C, S):
        for blk in prange(n_blocks):
            restart(np.int64(blk), P, C, S)

    def pass1_own(n_blocks, beta, a, P, C, S):
        for blk in prange(n_blocks):
            p1_own(np.int64(blk), beta, a, P, C, S)

    def pass1_partner(n_blocks, beta, a, P, C, S):
        for blk in prange(n_blocks):
            p1_partner(np.int64(blk), beta, a, P, C, S)

    def pass3(n_blocks, alpha, P, C, S):
        for blk in prange(n_blocks):
            p3(np.int64(blk), alpha, P, C, S)

    return (parallel(setup_particle_pass), parallel(setup_slot_pass), parallel(restart_pass),
            parallel(pass1_own), parallel(pass1_partner), parallel(pass3))


def lub_solver(lub_blocks, parallel, key):
    """The implicit lubrication solve (engine.implicit); ``advance``'s finish pass applies it.

    ``lub_solve(n_blocks, back, tau, warm, ...)``: the kick of length tau starts at
    v- = v - back acc: the half-step velocity (v holds the prediction v + dt a of the last
    drift, back = dt/2), or the state itself when priming (back = 0, tau = dt/2). The other
    loads of the particle pass give the free velocity v_f = v- + tau a, and preconditioned CG
    solves (C + W) lam = b (engine.implicit: b = J v_f + (1 - theta)/theta J v-) until
    r.D^-1 r <= tol^2 b.D^-1 b or ``max_iterations``, with every sum over fixed blocks. It
    starts from the impulses of the last step (``warm``: no list rebuild since) where they
    lower the objective below its value at 0, else from 0.

    ``lub_blocks``: the compiled block kernels of :func:`~millsim.engine.implicit.lub_kernels`;
    ``parallel``: compiles a function with parallel loops (the chunk runner's); ``key``: the
    variant's cache key (:func:`~millsim.engine.models.stable_identity`).
    """
    setup_particle_pass, setup_slot_pass, restart_pass, pass1_own, pass1_partner, pass3 = (
        _block_passes(lub_blocks, parallel))

    def pass1(n_blocks, beta, a, P, C, S):
        """u = M^-1 J^T p and the blocks' parts of p.(C + W) p (engine.implicit p1_own,
        p1_partner)."""
        pass1_own(n_blocks, beta, a, P, C, S)
        pass1_partner(n_blocks, beta, a, P, C, S)

    def block_sum(part, col):
        total = 0.0
        for blk in range(part.shape[0]):
            total += part[blk, col]
        return total

    def lub_solve(n_blocks, back, tau, warm, P, C, R, S, fp, counters):
        setup_particle_pass(n_blocks, back, tau, P, R, S)
        if warm:  # u = M^-1 J^T lam of the impulses kept from the last step
            pass1(n_blocks, 0.0, RW_LAM, P, C, S)
        setup_slot_pass(n_blocks, back, tau, warm, P, C, S)
        part = S.cg_part
        rho = block_sum(part, 1)
        if warm and block_sum(part, 0) < 0.0:
            # the kept impulses would raise the objective above f(0) = 0, where the energy
            # argument starts: from 0 then
            restart_pass(n_blocks, P, C, S)
            rho = block_sum(part, 1)
        stop_at = fp[3] * fp[3] * block_sum(part, 2)  # relative to b.D^-1 b, b = J v_f
        iterations = 0
        beta = 0.0
        while rho > stop_at and iterations < fp[4]:
            pass1(n_blocks, beta, RW_Z, P, C, S)
            pq = block_sum(part, 0)
            if not pq > 0.0:  # rounding at convergence: nothing left to reduce
                break
            pass3(n_blocks, rho / pq, P, C, S)
            rho_new = block_sum(part, 1)
            beta = rho_new / rho
            rho = rho_new
            iterations += 1
        counters[2] += iterations
        counters[3] = max(counters[3], iterations)

    block_sum = stable_identity(njit(cache=True)(block_sum), f"{key}|block_sum")
    pass1 = stable_identity(njit(cache=True)(pass1), f"{key}|pass1")
    lub_solve = stable_identity(njit(cache=True)(lub_solve), f"{key}|lub_solve")
    return lub_solve
