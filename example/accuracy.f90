!> The trade of speed for accuracy as one argument: the spring-linkage to T = 10 with a
!! requested error of 1e-20 (max |error| of q and p at T). `init_for_accuracy` chooses
!! (M, N, G), h and the Newton tolerance from a pilot and sets up the integrator; the run
!! is compared with one of 1280 steps of order 16 (converged to 1e-32).
!!
!!     fpm run --profile release --example accuracy
!!
!! Output:
!!     chosen: (M,N,G) = (8,7,9), 70 steps, Newton tolerance   3.6E-23
!!     estimated error   4.1E-21
!!     error at T        1.5E-21
program accuracy
    use holosym, only: wp, spring_linkage, constrained_integrator, accuracy_plan_t, &
        init_for_accuracy, holosym_status_t
    implicit none
    type(spring_linkage) :: sys
    type(constrained_integrator) :: integ, reference
    type(accuracy_plan_t) :: plan
    type(holosym_status_t) :: status
    real(wp) :: q(6), p(6), q_ref(6), p_ref(6)

    sys = spring_linkage()
    call sys%initial_state(q, p)
    q_ref = q
    p_ref = p
    call init_for_accuracy(integ, sys, q, p, 1.0e-20_wp, 10.0_wp, plan, status)
    if (.not. status%ok()) error stop status%message
    call integ%integrate(sys, q, p, plan%h, plan%steps, status=status)
    if (.not. status%ok()) error stop status%message

    call reference%init(sys, 8, 7, 9, status)
    call reference%integrate(sys, q_ref, p_ref, 10.0_wp / 1280, 1280, status=status)
    print '(a, 3(i0, a), i0, a, es9.1)', "chosen: (M,N,G) = (", plan%order_m, ",", &
        plan%order_n, ",", plan%gauss_points, "), ", plan%steps, &
        " steps, Newton tolerance ", real(plan%newton_tolerance)
    print '(a, es9.1)', "estimated error ", real(plan%estimate)
    print '(a, es9.1)', "error at T      ", &
        real(max(maxval(abs(q - q_ref)), maxval(abs(p - p_ref))))
end program accuracy
