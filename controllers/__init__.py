"""controllers: the dissertation's control design module (Chapter 4, Sec. 5.3).

Depends on numpy, scipy, python-control and osqp only -- never on mujoco or
vlab -- and takes plain matrices (m, c, k, U, sensor selection).
"""
