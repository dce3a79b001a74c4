"""Time stepping: state, Newton solver, linear solvers, implicit Euler stepper, static solve."""
