!> Paper Example 1: the spherical pendulum in the potential -m sin(z), l = m = 1,
!! q(0) = (0, sqrt2/2, sqrt2/2), p(0) = (0.6, 0, 0), integrated for 200 s with the best
!! combination N = M - 1 = G - 2 = 1 and h = 1/8 (the setting of the paper's Fig. 1).
!! The energy error stays bounded (no drift) and the constraint holds to round-off
!! (real128 epsilon is 1.9e-34) at every displacement node.
!!
!! Run: `fpm run --example spherical_pendulum` (about 3 s). Output:
!!
!!     Spherical pendulum (paper Example 1): (M, N, G) = (2, 1, 3), h = 1/8, 1600 steps
!!     state at t = 200:
!!       q      =  5.6142228189076226E-01 -2.8936967664913082E-01  7.7528718010331304E-01
!!       p      = -3.7442291720922819E-01 -5.6270910581803190E-01  6.1110795831038864E-02
!!       lambda =  5.0733614776621972E-01   (end of the last step)
!!     |q|^2 - 1 at t = 200:                           1.926E-34
!!     max |(H - H0)/H0| over 200 s (H0 = -0.4696):    5.365E-08
!!     max |phi| at the displacement nodes:            3.852E-34
!!     max |Phi H_p| at the step ends:                 5.537E-34
!!     Newton iterations per step:                          7.00
program example_spherical_pendulum
    use holosym, only: wp, spherical_pendulum, constrained_integrator, step_info_t, &
        holosym_status_t
    use spherical_pendulum_monitor, only: error_monitor
    implicit none
    !> Scheme: N = M - 1 = G - 2 = 1.
    integer, parameter :: order_m = 2, order_n = 1, gauss_points = 3
    !> Step size 1/2**3 and duration of the paper's Fig. 1.
    real(wp), parameter :: h = 1.0_wp / 8, final_time = 200.0_wp
    type(spherical_pendulum) :: sys
    type(constrained_integrator) :: integrator
    type(error_monitor) :: monitor
    type(holosym_status_t) :: status
    type(step_info_t) :: info
    real(wp) :: q(3), p(3)
    integer :: steps

    sys = spherical_pendulum()
    call sys%initial_state(q, p)
    call integrator%init(sys, order_m, order_n, gauss_points)
    allocate (monitor%sys, source=sys)
    monitor%energy0 = sys%hamiltonian(q, p)
    steps = nint(final_time / h)

    call integrator%integrate(sys, q, p, h, steps, monitor, status=status)
    if (.not. status%ok()) error stop status%message
    info = integrator%last_step()

    print '(a, 3(i0, a), i0, a)', "Spherical pendulum (paper Example 1): (M, N, G) = (", &
        order_m, ", ", order_n, ", ", gauss_points, "), h = 1/8, ", steps, " steps"
    print '(a, i0, a)', "state at t = ", nint(final_time), ":"
    print '(a, 3es24.16)', "  q      =", q
    print '(a, 3es24.16)', "  p      =", p
    print '(a, es24.16, a)', "  lambda =", info%lambda(1, order_m), "   (end of the last step)"
    print '(a, t48, es10.3)', "|q|^2 - 1 at t = 200:", abs(sum(q**2) - 1)
    print '(a, f7.4, a, t48, es10.3)', "max |(H - H0)/H0| over 200 s (H0 = ", &
        monitor%energy0, "):", monitor%max_energy_error
    print '(a, t48, es10.3)', "max |phi| at the displacement nodes:", monitor%max_constraint
    print '(a, t48, es10.3)', "max |Phi H_p| at the step ends:", monitor%max_velocity
    print '(a, t48, f10.2)', "Newton iterations per step:", &
        real(monitor%iterations, wp) / steps
end program example_spherical_pendulum
