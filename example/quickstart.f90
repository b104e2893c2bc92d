!> Quick start: the spherical pendulum of the paper's Example 1 (a system that comes with
!! holosym), integrated over t = 0..10 with (M, N, G) = (3, 2, 4), an order-6 scheme,
!! step by step, watching the energy error and the constraint.
!!
!! Run: `fpm run --profile release --example quickstart`. Output:
!!
!!     q(10)          = -0.315887631271325652 -0.569021269115290426  0.759229741056167552
!!     p(10)          = -0.611141803597033054  0.242210762453118049 -0.072743542933220399
!!     max |H/H0 - 1| = 1.011E-11
!!     max |phi|      = 3.852E-34
!!     Newton iterations in the last step: 6
program quickstart
    use holosym, only: wp, spherical_pendulum, constrained_integrator, step_info_t, &
        holosym_status_t
    implicit none
    type(spherical_pendulum) :: sys        ! H = |p|^2/2 - sin(z) on the sphere |q| = 1
    type(constrained_integrator) :: integ
    type(step_info_t) :: info
    type(holosym_status_t) :: status
    real(wp) :: q(3), p(3), energy0, energy_error, phi_max
    integer :: k

    sys = spherical_pendulum()             ! n = 3 coordinates, m = 1 constraint
    call sys%initial_state(q, p)           ! q = (0, sqrt2/2, sqrt2/2), p = (0.6, 0, 0)
    energy0 = sys%hamiltonian(q, p)
    call integ%init(sys, 3, 2, 4, status)  ! M = 3, N = M - 1, G = M + 1: order 2M = 6
    if (.not. status%ok()) error stop status%message
    energy_error = 0
    phi_max = 0
    do k = 1, 80                           ! 80 steps of h = 1/8
        call integ%step(sys, q, p, 0.125_wp, info, status)
        if (.not. status%ok()) error stop status%message  ! q, p are unchanged on failure
        energy_error = max(energy_error, abs(sys%hamiltonian(q, p) / energy0 - 1))
        phi_max = max(phi_max, info%constraint_residual)
    end do
    print '(a, 3f22.18)', "q(10)          =", q
    print '(a, 3f22.18)', "p(10)          =", p
    print '(a, es10.3)', "max |H/H0 - 1| =", energy_error
    print '(a, es10.3)', "max |phi|      =", phi_max
    print '(a, i0)', "Newton iterations in the last step: ", info%newton_iterations
end program quickstart
