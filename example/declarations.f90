!> Every optional declaration of a user's system, checked and used: the double pendulum of
!! `declared_double_pendulum`, once with the five procedures alone (general scheme,
!! difference Hessians) and once with every declaration (reduced step, exact Hessians,
!! sparse patterns, real64 gradient). The integrator checks the declarations at the first
!! step; both runs give the same states to round-off.
!!
!! Run: `fpm run --profile release --example declarations`.
!! Output:
!!     check of the declarations: passed, 16 comparisons made
!!     plain:    q(2) =  -0.2003688  -0.9797205   0.1958395  -1.8978812
!!     declared: q(2) =  -0.2003688  -0.9797205   0.1958395  -1.8978812
!!     largest difference of the two states: below 1e-30: T
program declarations
    use holosym, only: wp, constrained_integrator, holosym_status_t, check_system, &
        system_check_report_t
    use declared_double_pendulum, only: plain_double_pendulum, declared_double_pendulum_t
    implicit none
    type(plain_double_pendulum) :: plain
    type(declared_double_pendulum_t) :: declared
    type(constrained_integrator) :: integ_plain, integ_declared
    type(system_check_report_t) :: report
    type(holosym_status_t) :: status
    real(wp) :: q0(4), p0(4), qa(4), pa(4), qb(4), pb(4)

    plain%n = 4
    plain%m = 2
    declared%plain_double_pendulum = plain
    ! Rods at 1 and 0.5 rad from the downward vertical, at rest.
    q0 = [sin(1.0_wp), -cos(1.0_wp), sin(1.0_wp) + sin(0.5_wp), -cos(1.0_wp) - cos(0.5_wp)]
    p0 = 0
    call check_system(declared, q0, p0, report, status)    ! what the integrator runs
    if (.not. status%ok()) error stop status%message
    print '(a, i0, a)', "check of the declarations: passed, ", count(report%entries%made), &
        " comparisons made"
    call integ_plain%init(plain, 6, 5, 7, status)
    call integ_declared%init(declared, 6, 5, 7, status)
    qa = q0
    pa = p0
    qb = q0
    pb = p0
    call integ_plain%integrate(plain, qa, pa, 0.0625_wp, 32, status=status)
    if (.not. status%ok()) error stop status%message
    call integ_declared%integrate(declared, qb, pb, 0.0625_wp, 32, status=status)
    if (.not. status%ok()) error stop status%message
    print '(a, 4f12.7)', "plain:    q(2) =", qa
    print '(a, 4f12.7)', "declared: q(2) =", qb
    print '(a, l1)', "largest difference of the two states: below 1e-30: ", &
        max(maxval(abs(qa - qb)), maxval(abs(pa - pb))) < max(1.0e-30_wp, 1.0e4_wp * &
        epsilon(1.0_wp))
end program declarations
