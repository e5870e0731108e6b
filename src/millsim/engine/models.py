"""What the engine asks of a model, and the no-op hooks used when a scene has none.

The engine imports no model by name. A contact law, a breakage model or a fluid is an object a
scene hands to :class:`~millsim.engine.simulation.Simulation`; it brings

- ``kernels``: a :class:`BreakageKernels` / :class:`FluidKernels` of numba functions the step loop
  calls at fixed points (the *hooks*, documented below), compiled into the loop with
  ``inline="always"``;
- its layout: the per-contact state columns it owns (``contact_columns``, ``wall_columns``), the
  per-slot record columns it fills in the pair pass and reads in the particle pass
  (``slot_columns``), and its per-particle arrays (``particle_fields``: name -> (dtype, fill));
- its parameters as arrays (``params()``), and its time-step bounds.

The loop is compiled once per (physics spec, model kinds); a model's hooks are reached through the
compiled loop's closure, which numba can cache only when the functions have a stable identity
across processes (:func:`stable_identity`).

Hook signatures (``bs``: the breakage model's bundle, a namedtuple of its params and per-particle
arrays; ``state``: the contact-state table, ``base``: the model's first column in it; ``o``: the
slot record of contact ``k``, ``col``: the model's first column in it):

- ``pair_reference(bs, state, k, base, apart, rsum, dist2) -> (xi_ref, apart)``: overlap the
  pair's force does not see (fragments created overlapping), and whether the pair counts as apart.
- ``pair_apart(bs, state, k, base, o, col, step, i, j, radius, body, rsum, dist2, seen, stop)``:
  the contact event of slot k is over (or never began); ``seen`` <= 0 is the overlap the force
  would see (minus the gap).
- ``pair_override(bs, state, k, base, p, xi, n0, n1, n2, v0, v1, v2, m_eff) -> (active, fn)``: a
  normal force replacing the contact law (and no tangential force) while ``active``.
- ``pair_loaded(bs, state, k, base, o, col, fn, xi, material_i, material_j)``: after the force.
- ``slot_share(bs, acc, o, col, side) -> acc``: the particle pass gathering slot k for i (side 0)
  or j (side 1); ``acc`` = (work, largest normal force, its direction x, y, z).
- ``wall_reference(bs, hist, i, iw, base, xi) -> (xi_seen, touching)``. The wall hooks see
  ``hist[i, iw]``: particle i's state at analytic wall iw, or at its mesh contact in history
  slot iw (``mesh_hist``; engine.loop.wall_pass.mesh_kernel).
- ``wall_apart(bs, hist, i, iw, base, xi)``: particle i does not touch wall iw (xi <= 0; its
  contact state has just been cleared).
- ``wall_loaded(bs, hist, i, iw, base, xi_seen, fn, g0, g1, g2, material_i, material_w, acc) -> acc``.
- ``particle_decide(bs, i, acc, inv_mass, material, stop)``: after all contacts of particle i.
- ``collect(bs, events, n_events, out, col, start, nbr, inv_mass, step) -> events``: serial, when a hook
  stopped the chunk: the decisions as rows of ``events``.

Fluid hooks (``fp``: the fluid's parameter array):

- ``pair_fluid(fp, o, col_t, col_d, ri, rj, n0, n1, n2, h, v, w, i, j)``: pair force into o[0:3],
  torques on i and j into o[col_t:col_t+6], dissipation into o[col_d:col_d+2] (col_d < 0: none).
- ``wall_fluid(fp, wall, x, v, w, i, ri, n0, n1, n2, xi) -> (active, force(3), couple(3),
  dissipation normal, tangential, lever(3), power)``.

A fluid integrated implicitly (its ``implicit`` attribute true; :mod:`millsim.engine.implicit`)
writes resistance rows instead of forces: ``pair_fluid`` fills the row record at o[col_t:]
(``implicit.row_write``) and ``wall_rows(fp, wall, x, i, ri, n0, n1, n2, xi, rec)`` the record
``rec`` of particle i and that wall (``rec[RW_ACT] = 0`` beyond its reach); ``wall_fluid`` is
not called.
"""

import types
import uuid
from collections import namedtuple

import numpy as np
from numba import njit

BreakageKernels = namedtuple("BreakageKernels", [
    "pair_reference", "pair_apart", "pair_override", "pair_loaded", "slot_share",
    "wall_reference", "wall_apart", "wall_loaded", "particle_decide", "collect"])
FluidKernels = namedtuple("FluidKernels", ["pair_fluid", "wall_fluid", "wall_rows"])


def stable_identity(dispatcher, key):
    """Give a numba dispatcher the same identity in every process.

    numba keys its on-disk cache of a closure by the pickled closure variables, and a dispatcher
    pickles with a per-process random uuid: a loop that reaches its hooks through its closure would
    compile anew in every process (seen: every scene's loop, ~60 s per case). A uuid derived from
    ``key`` (which must name everything the function's code depends on) makes it cacheable. The
    module-level dispatchers its code calls (pickled with it, by value) get one from their
    qualified name. If a numba version drops this private method the loop still works, it only
    recompiles.
    """
    _set_stable_uuid(dispatcher, key)
    _stabilize_callees(dispatcher.py_func, set())
    return dispatcher


def _set_stable_uuid(dispatcher, key):
    if hasattr(dispatcher, "_set_uuid"):
        try:
            dispatcher._set_uuid(str(uuid.uuid5(uuid.NAMESPACE_URL, f"millsim:{key}")))
        except AssertionError:  # already has one (given before, or it was pickled before)
            pass


def _stabilize_callees(fn, seen):
    names, codes = set(), [fn.__code__]
    while codes:  # the names used by the function and the functions defined in it
        code = codes.pop()
        names.update(code.co_names)
        codes.extend(c for c in code.co_consts if isinstance(c, types.CodeType))
    callees = [fn.__globals__.get(name) for name in names]
    callees += [cell.cell_contents for cell in fn.__closure__ or ()]
    for obj in callees:
        py_func = getattr(obj, "py_func", None)
        if py_func is None or id(obj) in seen:
            continue
        seen.add(id(obj))
        if py_func.__closure__ is None:  # closures are named by whoever builds them
            _set_stable_uuid(obj, f"{py_func.__module__}.{py_func.__qualname__}")
        _stabilize_callees(py_func, seen)


def _hook(fn, key):
    return stable_identity(njit(inline="always", cache=True)(fn), f"engine.models.{key}")


# ---- no breakage ---------------------------------------------------------------------------------
def _no_pair_reference(bs, state, k, base, apart, rsum, dist2):
    return 0.0, apart


def _no_pair_apart(bs, state, k, base, o, col, step, i, j, radius, body, rsum, dist2, seen, stop):
    pass


def _no_pair_override(bs, state, k, base, p, xi, n0, n1, n2, v0, v1, v2, m_eff):
    return False, 0.0


def _no_pair_loaded(bs, state, k, base, o, col, fn, xi, material_i, material_j):
    pass


def _no_slot_share(bs, acc, o, col, side):
    return acc


def _no_wall_reference(bs, hist, i, iw, base, xi):
    return xi, True


def _no_wall_apart(bs, hist, i, iw, base, xi):
    pass


def _no_wall_loaded(bs, hist, i, iw, base, xi_seen, fn, g0, g1, g2, material_i, material_w, acc):
    return acc


def _no_particle_decide(bs, i, acc, inv_mass, material, stop):
    pass


def _no_collect(bs, events, n_events, out, col, start, nbr, inv_mass, step):
    return events


NO_BREAKAGE = BreakageKernels(*(_hook(f, f"no_breakage.{name}") for f, name in zip(
    (_no_pair_reference, _no_pair_apart, _no_pair_override, _no_pair_loaded, _no_slot_share,
     _no_wall_reference, _no_wall_apart, _no_wall_loaded, _no_particle_decide, _no_collect),
    BreakageKernels._fields)))


# ---- no fluid ------------------------------------------------------------------------------------
def _no_pair_fluid(fp, o, col_t, col_d, ri, rj, n0, n1, n2, h, v, w, i, j):
    pass


def _no_wall_fluid(fp, wall, x, v, w, i, ri, n0, n1, n2, xi):
    return False, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0


def _no_wall_rows(fp, wall, x, i, ri, n0, n1, n2, xi, rec):
    pass


NO_FLUID = FluidKernels(_hook(_no_pair_fluid, "no_fluid.pair_fluid"),
                        _hook(_no_wall_fluid, "no_fluid.wall_fluid"),
                        _hook(_no_wall_rows, "no_fluid.wall_rows"))


class ParticleModel:
    """Base of the models the engine hands hooks to (breakage, fluid); see the module text.

    Subclasses set the class attributes and implement :meth:`params`; the Simulation allocates
    ``particle_fields`` (one array per field, kept in step with added and removed particles) and
    calls :meth:`attach` once.
    """

    kind = ""  # "breakage" or "fluid"
    name = ""  # e.g. "weibull"; part of the compiled loop's identity
    contact_columns = ()
    wall_columns = ()
    slot_columns = ()
    particle_fields = {}
    event_columns = 0
    implicit = False  # a fluid whose resistance the loop integrates implicitly (engine.implicit)

    def attach(self, sim):
        """Called once by the Simulation that owns this model (after particles exist)."""
        self.sim = sim

    def __getstate__(self):
        # ``fields`` is a tuple of a class made at run time (no checkpoint can name it); the
        # Simulation publishes it again when it is loaded.
        return {k: v for k, v in self.__dict__.items() if k != "fields"}

    def params(self):
        """The parameters the hooks read (a float64 array)."""
        return np.zeros(0)

    def bundle(self, fields):
        """What the hooks receive as ``bs``: params and the per-particle arrays (namedtuple)."""
        raise NotImplementedError

    def step_bounds(self, smallest):
        """Time-step bounds this model adds (``smallest``: see engine.timestep); none by default."""
        return ()

    def reset_events(self):
        """Forget any event in progress (``Simulation.restart_free_flight``)."""

    def records(self, rows):
        """The event-table rows of a chunk as named records."""
        return []

    def reference_overlap(self, state):
        """Overlap the force does not see, per contact-state row (the model's columns); 0 here."""
        return np.zeros(len(state))
