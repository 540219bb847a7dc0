"""Planted bugs of `mutation_check.py`: the smoother's Levenberg–Marquardt step rules (Nielsen's
update of the damping, and when an accepted step's decrease may end the iteration: a barely
damped step, read from the damping or from how much it shortens the step)."""

# name: (file, [(old, new), ...], tests that should fail)
MUTATIONS = {
    "the smoother ignores the shortfall (settled runs use their whole budget)": (
        "vojax/_tracker/_smoother.py",
        [("        share = _damping.BARELY_DAMPED\n", "        share = 0.0\n")],
        ["tests/test_convergence.py"],
    ),
    "a step's shortfall read on its least smoothed variance": (
        "vojax/_tracker/_damping.py",
        [("    return mu * jnp.max(jnp.diagonal(", "    return mu * jnp.min(jnp.diagonal(")],
        ["tests/test_convergence.py"],
    ),
    "a shortfall within the share needed as well as the starting damping": (
        "vojax/_tracker/_damping.py",
        [("        barely = barely | (short <= share)", "        barely = barely & (short <= share)")],
        ["tests/test_convergence.py"],
    ),
    "smoother's damping falls by ρ, not by Nielsen's cubic": (
        "vojax/_tracker/_damping.py",
        [("scale = jnp.maximum(MU_DOWN, 1.0 - (2.0 * rho - 1.0) ** 3)",
          "scale = jnp.maximum(MU_DOWN, 1.0 - rho)")],
        ["tests/test_kalman.py::test_damping_follows_nielsens_rule"],
    ),
    "smoother's damping keeps growing after an accepted step (ν not reset)": (
        "vojax/_tracker/_damping.py",
        [("jnp.where(accepted, jnp.full_like(nu, 2.0), 2.0 * nu)", "2.0 * nu")],
        ["tests/test_kalman.py::test_damping_follows_nielsens_rule"],
    ),
    "a heavily damped step's tiny decrease ends the smoother's iteration": (
        "vojax/_tracker/_damping.py",
        [("    barely = mu <= MU_START\n", "    barely = mu <= jnp.inf\n")],
        ["tests/test_convergence.py::test_only_a_barely_damped_step_can_end_the_iteration"],
    ),
}
