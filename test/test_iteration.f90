!> Tests of the reduced step's iteration without the Newton matrix (`iteration =
!! 'automatic'`, the default): where it contracts it is used and gives the states of the
!! Newton iteration (`iteration = 'newton'`) to round-off with fewer Newton matrices;
!! where it does not (h too large for it) the step falls back to the Newton matrix and
!! still agrees; a bad value of the setting is refused; the command line passes it on.
module test_iteration
    use holosym_kinds, only: wp
    use holosym_status_codes, only: holosym_status_t, real_str, int_str, HOLOSYM_SUCCESS, &
        HOLOSYM_INVALID_ARGUMENT
    use holosym_problem, only: constrained_hamiltonian
    use holosym_integrator, only: constrained_integrator
    use holosym_models, only: spherical_pendulum, spring_linkage, planar_pendulum
    use holosym_model_chain, only: pendulum_chain
    use holosym_test_systems, only: uneven_chain
    use holosym_testing, only: test_case_t, new_test, test_error_t, check, check_status_code
    use holosym_test_commands, only: command_result_t, run_holosym, words, any_line_contains
    implicit none
    private
    public :: iteration_tests

    real(wp), parameter :: eps = epsilon(1.0_wp)
    !> Agreement of the two iterations after tens of steps: both meet the Newton tolerance
    !! (8 epsilon) at every step, so they differ by round-off grown over the run.
    real(wp), parameter :: agreement = max(1.0e-30_wp, 1.0e4_wp * eps)

    !> What one run did.
    type :: run_t
        real(wp), allocatable :: q(:), p(:)
        integer :: code = -1
        integer(kind=8) :: approximate = 0, factorizations = 0
    end type run_t

contains

    !> The tests of this suite.
    function iteration_tests() result(tests)
        type(test_case_t), allocatable :: tests(:)
        tests = [ &
            new_test("agrees_with_newton_iteration", agrees_with_newton), &
            new_test("large_h_falls_back_to_newton_matrix", falls_back), &
            new_test("contraction_limit_acts_on_it", contraction_limit), &
            new_test("bad_value_refused", bad_value), &
            new_test("cli_iteration_option", cli_option) &
        ]
    end function iteration_tests

    !> `steps` steps of h with (M, N, G) and `iteration` from (q0, p0).
    function run(sys, q0, p0, orders, h, steps, iteration, limit) result(r)
        class(constrained_hamiltonian), intent(in) :: sys
        real(wp), intent(in) :: q0(:), p0(:), h
        integer, intent(in) :: orders(3), steps
        character(len=*), intent(in) :: iteration
        real(wp), intent(in), optional :: limit !! newton%contraction_limit
        type(run_t) :: r
        type(constrained_integrator) :: integ
        type(holosym_status_t) :: status
        integ%iteration = iteration
        if (present(limit)) integ%newton%contraction_limit = limit
        r%q = q0
        r%p = p0
        call integ%init(sys, orders(1), orders(2), orders(3), status)
        if (status%ok()) call integ%integrate(sys, r%q, r%p, h, steps, status=status)
        r%code = status%code
        r%approximate = integ%stats%approximate_iterations
        r%factorizations = integ%stats%lu_factorizations
    end function run

    !> Both iterations on one case: success, the same states to `agreement`; the
    !! automatic one used the iteration without the Newton matrix and formed fewer
    !! Newton matrices.
    subroutine compare(error, sys, q0, p0, orders, h, steps, label)
        type(test_error_t), allocatable, intent(inout) :: error
        class(constrained_hamiltonian), intent(in) :: sys
        real(wp), intent(in) :: q0(:), p0(:), h
        integer, intent(in) :: orders(3), steps
        character(len=*), intent(in) :: label
        type(run_t) :: auto, newton
        real(wp) :: difference, scale
        if (allocated(error)) return
        auto = run(sys, q0, p0, orders, h, steps, "automatic")
        newton = run(sys, q0, p0, orders, h, steps, "newton")
        call check_status_code(error, auto%code, HOLOSYM_SUCCESS, label // ": automatic")
        call check_status_code(error, newton%code, HOLOSYM_SUCCESS, label // ": newton")
        if (allocated(error)) return
        scale = max(1.0_wp, maxval(abs(newton%q)), maxval(abs(newton%p)))
        difference = max(maxval(abs(auto%q - newton%q)), maxval(abs(auto%p - newton%p)))
        call check(error, difference <= agreement * scale, label // ": iterations differ by " &
            // real_str(difference))
        call check(error, auto%approximate >= steps .and. newton%approximate == 0, label // &
            ": iterations without the Newton matrix " // int_str(int(auto%approximate)) // &
            " (automatic), " // int_str(int(newton%approximate)) // " (newton)")
        call check(error, auto%factorizations < newton%factorizations, label // &
            ": Newton matrices " // int_str(int(auto%factorizations)) // " (automatic), " // &
            int_str(int(newton%factorizations)) // " (newton)")
    end subroutine compare

    subroutine agrees_with_newton(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(spherical_pendulum) :: sphere
        type(spring_linkage) :: linkage
        type(planar_pendulum) :: planar
        type(pendulum_chain) :: chain
        real(wp) :: q3(3), p3(3), q6(6), p6(6), q2(2), p2(2), q8(8), p8(8)
        sphere = spherical_pendulum()
        call sphere%initial_state(q3, p3)
        call compare(error, sphere, q3, p3, [4, 3, 5], 0.0625_wp, 32, "sphere (4,3,5)")
        call compare(error, sphere, q3, p3, [8, 7, 9], 0.125_wp, 24, "sphere (8,7,9)")
        linkage = spring_linkage()
        call linkage%initial_state(q6, p6)
        call compare(error, linkage, q6, p6, [6, 5, 7], 0.0625_wp, 32, "linkage (6,5,7)")
        planar = planar_pendulum()
        call planar%initial_state(q2, p2)
        call compare(error, planar, q2, p2, [4, 3, 5], 0.0625_wp, 32, "planar (4,3,5)")
        call uneven_chain(chain, q8, p8)
        call compare(error, chain, q8, p8, [4, 3, 5], 0.01_wp, 40, "chain of 4 (4,3,5)")
    end subroutine agrees_with_newton

    !> At h = 5/7 the spherical pendulum's curvature (h^2 |lambda phi''| / m of order 1)
    !! leaves the iteration without the Newton matrix no contraction: the steps fall back
    !! to the Newton matrix (one or more per step) and agree with the Newton iteration.
    subroutine falls_back(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(spherical_pendulum) :: sphere
        type(run_t) :: auto, newton
        real(wp) :: q(3), p(3), difference
        integer, parameter :: steps = 28
        sphere = spherical_pendulum()
        call sphere%initial_state(q, p)
        auto = run(sphere, q, p, [5, 4, 5], 5.0_wp / 7, steps, "automatic")
        newton = run(sphere, q, p, [5, 4, 5], 5.0_wp / 7, steps, "newton")
        call check_status_code(error, auto%code, HOLOSYM_SUCCESS, "automatic")
        call check_status_code(error, newton%code, HOLOSYM_SUCCESS, "newton")
        if (allocated(error)) return
        difference = max(maxval(abs(auto%q - newton%q)), maxval(abs(auto%p - newton%p)))
        call check(error, difference <= agreement * 10, "iterations differ by " // &
            real_str(difference))
        call check(error, auto%factorizations >= steps .and. auto%approximate < steps, &
            int_str(int(auto%factorizations)) // " Newton matrices and " // &
            int_str(int(auto%approximate)) // " iterations without one in " // &
            int_str(steps) // " steps")
    end subroutine falls_back

    !> newton%contraction_limit, when given, is the contraction the iteration without the
    !! Newton matrix must achieve: 1e-30 (never met) leaves it after its first measured
    !! contraction, so each solve forms the Newton matrix, as with 'newton'.
    subroutine contraction_limit(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(planar_pendulum) :: planar
        type(run_t) :: strict, default
        real(wp) :: q(2), p(2)
        integer, parameter :: steps = 32
        planar = planar_pendulum()
        call planar%initial_state(q, p)
        strict = run(planar, q, p, [4, 3, 5], 0.0625_wp, steps, "automatic", 1.0e-30_wp)
        default = run(planar, q, p, [4, 3, 5], 0.0625_wp, steps, "automatic")
        call check(error, strict%code == HOLOSYM_SUCCESS .and. default%code == &
            HOLOSYM_SUCCESS, "runs: " // int_str(strict%code) // ", " // int_str(default%code))
        if (allocated(error)) return
        call check(error, strict%factorizations >= steps .and. &
            default%factorizations < strict%factorizations, "Newton matrices " // &
            int_str(int(strict%factorizations)) // " (limit 1e-30), " // &
            int_str(int(default%factorizations)) // " (default)")
    end subroutine contraction_limit

    !> An unknown value is refused before the step, naming the setting; the state stays.
    subroutine bad_value(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(planar_pendulum) :: planar
        type(constrained_integrator) :: integ
        type(holosym_status_t) :: status
        real(wp) :: q(2), p(2), q0(2), p0(2)
        planar = planar_pendulum()
        call planar%initial_state(q0, p0)
        q = q0
        p = p0
        call integ%init(planar, 4, 3, 5, status)
        integ%iteration = "fixed-point"
        call integ%step(planar, q, p, 0.0625_wp, status=status)
        call check_status_code(error, status%code, HOLOSYM_INVALID_ARGUMENT, "iteration")
        if (allocated(error)) return
        call check(error, index(status%message, "iteration") > 0 .and. all(q == q0) .and. &
            all(p == p0), "message '" // status%message // "', state kept")
    end subroutine bad_value

    !> `holosym simulate --iteration newton` runs without the iteration without the Newton
    !! matrix (the summary counts 0 such iterations), the default uses it, and an unknown
    !! value is refused with exit status 2 naming the option.
    subroutine cli_option(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(command_result_t) :: newton, default, bad
        call run_holosym("simulate --system planar --M 4 --h 1/16 --steps 16 --every 16 " // &
                         "--iteration newton", newton)
        call run_holosym("simulate --system planar --M 4 --h 1/16 --steps 16 --every 16", default)
        call run_holosym(words("simulate", "--system", "planar", "--iteration", "picard"), bad)
        call check(error, newton%exit_code == 0 .and. default%exit_code == 0, &
            "exit codes " // int_str(newton%exit_code) // ", " // int_str(default%exit_code))
        if (allocated(error)) return
        call check(error, any_line_contains(newton%err, "; 0 without the Newton matrix") .and. &
            .not. any_line_contains(default%err, "; 0 without the Newton matrix"), &
            "summaries name the iterations without the Newton matrix")
        call check(error, bad%exit_code == 2 .and. any_line_contains(bad%err, "--iteration"), &
            "unknown value: exit " // int_str(bad%exit_code))
    end subroutine cli_option

end module test_iteration
