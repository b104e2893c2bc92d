!> The speed options of the integrator on the spherical pendulum: the plain path (the
!! general scheme with the momenta as unknowns, full Newton, real128 LU, difference
!! Hessians, fresh first guess) against the defaults (the reduced step, which the model's
!! constant diagonal mass matrix allows: momenta eliminated, a fixed-point iteration without
!! the Newton matrix where it contracts and simplified Newton with real64 factors where it
!! does not, real64 first iterations, exact Hessians, extrapolated guess). Both give the
!! same state to round-off; the default is many times cheaper per step.
!!
!!     fpm run --profile release --example speed_options
!!
!! Output (CPU seconds per step vary with the machine):
!!     (M,N,G) = (7,6,8), h = 1/8, 80 steps
!!     plain:  8.59E-03 s/step, fast:  9.72E-05 s/step, speed-up   88.4
!!     states differ by  1.21E-32
!!     LU factorisations: plain 480, fast 80
!!     iterations: plain 480, fast 400 (240 without the Newton matrix)
program speed_options
    use holosym, only: wp, spherical_pendulum, constrained_integrator, holosym_status_t
    implicit none
    integer, parameter :: steps = 80
    real(wp), parameter :: h = 0.125_wp
    type(spherical_pendulum) :: sys
    type(constrained_integrator) :: plain, fast
    type(holosym_status_t) :: status
    real(wp) :: q_plain(3), p_plain(3), q_fast(3), p_fast(3)
    real :: start, plain_seconds, fast_seconds
    character(len=8) :: mode

    sys = spherical_pendulum()
    call sys%initial_state(q_plain, p_plain)
    q_fast = q_plain
    p_fast = p_plain
    ! The plain path: the general scheme and none of its speed options.
    plain%structured = .false.
    call plain%init(sys, 7, 6, 8, status)
    call fast%init(sys, 7, 6, 8, status)
    plain%newton%simplified = .false.
    plain%linear_solver = "real128"
    plain%hessians = "differences"
    plain%extrapolate = .false.
    plain%newton%presolve = .false.
    plain%linear_increments = .false.
    ! The defaults (`fast` is left as `init` made it).

    ! `speed_options fast` runs only the fast path (for profiling).
    mode = ""
    if (command_argument_count() >= 1) call get_command_argument(1, mode)
    call cpu_time(start)
    if (mode /= "fast") call plain%integrate(sys, q_plain, p_plain, h, steps, status=status)
    call cpu_time(plain_seconds)
    plain_seconds = plain_seconds - start
    call cpu_time(start)
    call fast%integrate(sys, q_fast, p_fast, h, steps, status=status)
    call cpu_time(fast_seconds)
    fast_seconds = fast_seconds - start
    print '(a, i0, a)', "(M,N,G) = (7,6,8), h = 1/8, ", steps, " steps"
    print '(a, es9.2, a, es9.2, a, f6.1)', "plain: ", plain_seconds / steps, " s/step, fast: ", &
        fast_seconds / steps, " s/step, speed-up ", plain_seconds / fast_seconds
    print '(a, es9.2)', "states differ by ", &
        real(max(maxval(abs(q_fast - q_plain)), maxval(abs(p_fast - p_plain))))
    print '(a, i0, a, i0)', "LU factorisations: plain ", plain%stats%lu_factorizations, &
        ", fast ", fast%stats%lu_factorizations
    print '(a, i0, a, i0, a, i0, a)', "iterations: plain ", plain%stats%newton_iterations, &
        ", fast ", fast%stats%newton_iterations, " (", fast%stats%approximate_iterations, &
        " without the Newton matrix)"
end program speed_options
