"""Registry of the built-in effects that carry a state per chamber (a state term).

A state term is one module's business: the module holding its physics (a
transducer lag, a wall with a thermal capacity, ...) defines its compiled rate,
names its parameters and states with their units, says where its states start,
and registers itself here with :func:`register_state_term`. Nothing else is
edited to add one: the registry assigns its slots (a block of the compiled
core's parameter vector and a block of its optional-state positions,
:mod:`pneucore.core.layout` places the blocks after the base slots) and the
core calls every registered rate from one table
(:data:`pneucore.core.rhs.state_terms`), the way it calls the flow and friction
laws.

Every state term has one state per chamber (``<state>`` for A then B) and one
rate law for both, with the signature

``rate(y_s, p, T, Q, S, T_amb, prm, k0) -> dy_s``

``y_s`` the state, ``p`` [Pa], ``T`` [K] the chamber's gas, ``Q`` [W] the
heat flow from its wall into the gas, ``S`` [m^2] its wall area, ``T_amb`` [K]
the ambient temperature, and the term's parameters in ``prm[k0:k0 + n]`` in the
order of :attr:`StateTerm.parameters`.

A line term (:class:`LineTerm`, registered with :func:`register_line_term`) is an effect
with a variable number of states on each port, between the valve's edges and the chamber
(a line resolved in segments, :mod:`pneucore.physics.tube`). The registry assigns it a block
of parameter slots per port and one state position per port (its first state); the core
asks it for the state of the node the valve edges see (``node``) and hands it the valve's
flow into the port, from which it returns the flow into the chamber (``rate``), calling
both from one table (:data:`pneucore.core.rhs.line_terms`). A line term also states its
structure (``cells``): the cell each of its states belongs to. Its contract, from which the
core derives the Jacobian's structural sparsity (:mod:`pneucore.core.integrator`): the
rates of a state of cell ``i`` read only the states of cells ``i - 1`` to ``i + 1`` of
the same port, the first cell's and the last cell's also the rest of the model (the valve
at one end, the chamber at the other), and the rest of the model reads only the states of
the first and the last cells. This module imports nothing from the core: physics stays
below it.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable


@dataclass(frozen=True)
class StateTerm:
    """A registered effect with one state per chamber.

    Parameters
    ----------
    name : str
        Registry name
    rate : callable
        Compiled rate law (module docstring's signature) [state unit / s]
    parameters : tuple
        ``(name, unit)`` of each parameter, in the order of its slots
    states : tuple
        ``(name of chamber A's state, name of chamber B's state)``
    state_unit : str
        SI unit of the states
    start : callable
        ``start(p_a, p_b, T_a, T_b, T_amb, p_sup) -> ((y_a, atol_a), (y_b, atol_b))``:
        initial states and absolute tolerances
    frozen_with_constant_b : bool
        Chamber B's state keeps its initial value when chamber B is held at a constant
        pressure (3/2 valve)
    description : str
        One line
    """
    name: str
    rate: Callable
    parameters: tuple
    states: tuple
    state_unit: str
    start: Callable
    frozen_with_constant_b: bool = False
    description: str = ""

    @property
    def n_parameters(self):
        """Number of parameter slots."""
        return len(self.parameters)

    @property
    def n_positions(self):
        """Number of state positions (one per chamber)."""
        return len(self.states)


@dataclass(frozen=True)
class LineTerm:
    """A registered effect with a variable number of states on each port, between the valve
    and the chamber.

    Parameters
    ----------
    name : str
        Registry name
    node : callable
        Compiled ``node(y, i0, prm, k0, r) -> (p, T)``: pressure [Pa] and temperature [K]
        of the node the port's valve edges see, the port's states starting at ``y[i0]``
        and its parameters at ``prm[k0]``
    rate : callable
        Compiled ``rate(y, dy, i0, prm, k0, q, H, p, T, r, cp, cv, isothermal, C_end, b_end,
        r_lam, gamma) -> (q_c, H_c)``: writes the derivatives of the port's states given the
        valve's mass flow ``q`` [kg/s] and enthalpy flow ``H`` [W] into the port and the
        chamber's ``p`` [Pa] and ``T`` [K]; a restriction at the chamber's end of conductance
        ``C_end`` [m^3/(s Pa)] (< 0: none) and critical ratio ``b_end`` [-] (an end cushion's
        needle) passes the gas leaving the chamber; returns the mass flow [kg/s] and
        enthalpy flow [W] into the chamber
    cells : callable
        Compiled ``cells(prm, k0, i0, cell) -> (n_states, n_cells)``: writes into
        ``cell[i0 + k]`` the cell (0 at the valve) of the port's ``k``-th state, and returns
        the port's number of states and of cells (module docstring: the structure the core's
        Jacobian relies on)
    parameters : tuple
        ``(name, unit)`` of each parameter of one port, in the order of its slots
    description : str
        One line
    """
    name: str
    node: Callable
    rate: Callable
    cells: Callable
    parameters: tuple
    description: str = ""

    @property
    def n_parameters(self):
        """Number of parameter slots (the port's block for each of the two ports)."""
        return 2 * len(self.parameters)

    @property
    def n_positions(self):
        """Number of state positions (the first state of each port's block)."""
        return 2


#: The state terms by name, in registration order (their slots follow that order)
STATE_TERMS: dict = {}


def register_state_term(term):
    """Add a built-in state term; its slots follow those of the terms registered before.

    Parameters
    ----------
    term : StateTerm
        The term (a name not yet registered, two states)

    Returns
    -------
    term : StateTerm
        The registered term
    """
    if term.name in STATE_TERMS:
        raise ValueError(f"state term {term.name!r} is already registered")
    if len(term.states) != 2:
        raise ValueError("a state term has one state per chamber (two names)")
    STATE_TERMS[term.name] = term
    return term


#: The line terms by name, in registration order (their slots follow the state terms')
LINE_TERMS: dict = {}


def register_line_term(term):
    """Add a built-in line term; its slots follow those of the terms registered before.

    Parameters
    ----------
    term : LineTerm
        The term (a name not yet registered as a state or line term)

    Returns
    -------
    term : LineTerm
        The registered term
    """
    if term.name in LINE_TERMS or term.name in STATE_TERMS:
        raise ValueError(f"term {term.name!r} is already registered")
    LINE_TERMS[term.name] = term
    return term


def slot_blocks(terms=None):
    """Relative slot blocks of the registered terms.

    Parameters
    ----------
    terms : dict or None
        Terms by name (default: :data:`STATE_TERMS`, then :data:`LINE_TERMS`)

    Returns
    -------
    prm0, iy0 : dict
        First parameter slot and first state-position slot of each term, counted from
        the start of the state terms' blocks
    n_prm, n_iy : int
        Total parameter slots and state-position slots
    """
    terms = {**STATE_TERMS, **LINE_TERMS} if terms is None else terms
    prm0, iy0, n_prm, n_iy = {}, {}, 0, 0
    for name, term in terms.items():
        prm0[name], iy0[name] = n_prm, n_iy
        n_prm += term.n_parameters
        n_iy += term.n_positions
    return prm0, iy0, n_prm, n_iy
