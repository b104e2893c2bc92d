!> Tests of the speed options of the integrator: every option, alone and combined, gives
!! the same states as the plain path (full Newton, real128 LU, difference Hessians, fresh
!! first guess each step) to 1e-30, and the work counters show the savings. These are the
!! options of the general scheme (all unknowns, dense Newton): `structured = .false.` keeps
!! the models, which declare a diagonal mass matrix, on it (the reduced step: test_reduced).
module test_speed
    use, intrinsic :: iso_fortran_env, only: int64
    use holosym_kinds, only: wp, dp
    use holosym_status_codes, only: holosym_status_t, real_str, int_str, HOLOSYM_SUCCESS, &
        HOLOSYM_INVALID_ARGUMENT, HOLOSYM_SINGULAR_MATRIX
    use holosym_problem, only: constrained_hamiltonian, difference_hessian, &
        difference_constraint_hessian
    use holosym_integrator, only: constrained_integrator, step_info_t
    use holosym_models, only: spherical_pendulum, spring_linkage, planar_pendulum
    use holosym_testing, only: test_case_t, new_test, test_error_t, check, check_status_code
    implicit none
    private
    public :: speed_tests

    !> Largest allowed difference between the states of two paths: 1e-30, or, in a real64
    !! build, its analogue 1e4 epsilon.
    real(wp), parameter :: same_results = max(1.0e-30_wp, 1.0e4_wp * epsilon(1.0_wp))
    !> Steps per comparison run and their size.
    integer, parameter :: run_steps = 12
    real(wp), parameter :: run_h = 0.25_wp
    !> Option sets compared with the plain path: simplified, linear solver, jacobian,
    !! hessians, extrapolate.
    integer, parameter :: variant_count = 10
    !> The option set with every fast option but the real64 pre-solve.
    integer, parameter :: fast_without_presolve = 8
    !> Steps of the large-step runs (T = 10, h = 5/7).
    integer, parameter :: large_steps = 14

contains

    !> Analytic and difference Hessians agree to about epsilon**(2/3), relative (a function:
    !! not every compiler folds real128 powers in a named constant).
    pure real(wp) function hessian_agreement()
        hessian_agreement = 100 * epsilon(1.0_wp)**(2.0_wp / 3)
    end function hessian_agreement

    !> The tests of this suite.
    function speed_tests() result(tests)
        type(test_case_t), allocatable :: tests(:)
        tests = [ &
            new_test("analytic_hessians_match_differences", analytic_hessians), &
            new_test("options_same_results_pendulum_213", options_pendulum_213), &
            new_test("options_same_results_pendulum_768", options_pendulum_768), &
            new_test("options_same_results_linkage_324", options_linkage_324), &
            new_test("options_same_results_planar_435", options_planar_435), &
            new_test("fast_path_saves_factorisations", fast_saves_work), &
            new_test("statistics_count_and_reset", statistics_counters), &
            new_test("unknown_option_values_rejected", unknown_options), &
            new_test("mixed_solver_detects_singular_jacobian", mixed_singular), &
            new_test("simplified_survives_step_size_change", simplified_step_change), &
            new_test("simplified_refactors_when_it_pays", simplified_refactor_policy), &
            new_test("presolve_saves_working_precision_residuals", presolve_saves), &
            new_test("linear_increments_save_an_evaluation", linear_increments_save), &
            new_test("fast_defaults_keep_constraints_at_round_off", fast_defaults_constraints) &
        ]
    end function speed_tests

    !> Configure `integ` as option set `variant` (0 = the plain path, variant_count = all fast).
    subroutine configure(integ, variant, label)
        type(constrained_integrator), intent(inout) :: integ
        integer, intent(in) :: variant
        character(len=:), allocatable, intent(out) :: label
        integ%newton%simplified = .false.
        integ%newton%presolve = .false.
        integ%linear_solver = "real128"
        integ%jacobian = "assembled"
        integ%hessians = "differences"
        integ%extrapolate = .false.
        integ%linear_increments = .false.
        select case (variant)
        case (0)
            label = "plain"
        case (1)
            integ%hessians = "user"
            label = "user hessians"
        case (2)
            integ%extrapolate = .true.
            label = "extrapolate"
        case (3)
            integ%newton%simplified = .true.
            label = "simplified"
        case (4)
            integ%linear_solver = "mixed"
            label = "mixed"
        case (5)
            integ%jacobian = "residual-differences"
            label = "residual differences"
        case (6)
            integ%newton%simplified = .true.
            integ%linear_solver = "mixed"
            label = "simplified + mixed"
        case (7)
            integ%linear_solver = "mixed"
            integ%newton%presolve = .true.
            label = "mixed + real64 pre-solve"
        case (fast_without_presolve)
            integ%newton%simplified = .true.
            integ%linear_solver = "mixed"
            integ%hessians = "user"
            integ%extrapolate = .true.
            integ%linear_increments = .true.
            label = "all fast options but the pre-solve"
        case (9)
            integ%linear_increments = .true.
            label = "linear increments"
        case default
            integ%newton%presolve = .true.
            integ%newton%simplified = .true.
            integ%linear_solver = "mixed"
            integ%hessians = "user"
            integ%extrapolate = .true.
            integ%linear_increments = .true.
            label = "all fast options"
        end select
    end subroutine configure

    !> Run `steps` steps with option set `variant`; return the end state and the stats.
    subroutine run_variant(sys, q0, p0, order_m, order_n, gauss_points, h, steps, variant, &
                           q, p, factorizations, status)
        class(constrained_hamiltonian), intent(in) :: sys
        real(wp), intent(in) :: q0(:), p0(:), h
        integer, intent(in) :: order_m, order_n, gauss_points, steps, variant
        real(wp), intent(out) :: q(:), p(:)
        integer, intent(out) :: factorizations
        type(holosym_status_t), intent(out) :: status
        type(constrained_integrator) :: integ
        character(len=:), allocatable :: label
        q = q0
        p = p0
        factorizations = 0
        integ%structured = .false.
        call integ%init(sys, order_m, order_n, gauss_points, status)
        if (.not. status%ok()) return
        call configure(integ, variant, label)
        call integ%integrate(sys, q, p, h, steps, status=status)
        factorizations = int(integ%stats%lu_factorizations)
    end subroutine run_variant

    !> Every option set against the plain path on one system and (M, N, G).
    subroutine compare_options(error, sys, q0, p0, order_m, order_n, gauss_points, name)
        type(test_error_t), allocatable, intent(inout) :: error
        class(constrained_hamiltonian), intent(in) :: sys
        real(wp), intent(in) :: q0(:), p0(:)
        integer, intent(in) :: order_m, order_n, gauss_points
        character(len=*), intent(in) :: name
        real(wp) :: q_plain(size(q0)), p_plain(size(p0)), q(size(q0)), p(size(p0)), difference
        type(holosym_status_t) :: status
        type(constrained_integrator) :: dummy
        character(len=:), allocatable :: label
        integer :: variant, factorizations

        call run_variant(sys, q0, p0, order_m, order_n, gauss_points, run_h, run_steps, 0, &
                         q_plain, p_plain, factorizations, status)
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, name // " plain run")
        if (allocated(error)) return
        do variant = 1, variant_count
            call configure(dummy, variant, label)
            call run_variant(sys, q0, p0, order_m, order_n, gauss_points, run_h, run_steps, &
                             variant, q, p, factorizations, status)
            call check_status_code(error, status%code, HOLOSYM_SUCCESS, name // " " // label)
            if (allocated(error)) return
            difference = max(maxval(abs(q - q_plain)), maxval(abs(p - p_plain)))
            call check(error, difference <= same_results, name // ": " // label // &
                " differs from the plain path by " // real_str(difference) // " after " // &
                int_str(run_steps) // " steps")
        end do
    end subroutine compare_options

    subroutine options_pendulum_213(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(spherical_pendulum) :: sys
        real(wp) :: q(3), p(3)
        sys = spherical_pendulum()
        call sys%initial_state(q, p)
        call compare_options(error, sys, q, p, 2, 1, 3, "pendulum (2,1,3)")
    end subroutine options_pendulum_213

    subroutine options_pendulum_768(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(spherical_pendulum) :: sys
        real(wp) :: q(3), p(3)
        sys = spherical_pendulum()
        call sys%initial_state(q, p)
        call compare_options(error, sys, q, p, 7, 6, 8, "pendulum (7,6,8)")
    end subroutine options_pendulum_768

    subroutine options_linkage_324(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(spring_linkage) :: sys
        real(wp) :: q(6), p(6)
        sys = spring_linkage()
        call sys%initial_state(q, p)
        call compare_options(error, sys, q, p, 3, 2, 4, "linkage (3,2,4)")
    end subroutine options_linkage_324

    subroutine options_planar_435(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(planar_pendulum) :: sys
        real(wp) :: q(2), p(2)
        sys = planar_pendulum()
        call sys%initial_state(q, p)
        call compare_options(error, sys, q, p, 4, 3, 5, "planar (4,3,5)")
    end subroutine options_planar_435

    !> The models' exact second derivatives agree with the difference defaults.
    subroutine analytic_hessians(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(spherical_pendulum) :: sphere
        type(spring_linkage) :: linkage
        type(planar_pendulum) :: planar
        real(wp) :: q3(3), p3(3), q6(6), p6(6), q2(2), p2(2)
        sphere = spherical_pendulum()
        linkage = spring_linkage()
        planar = planar_pendulum()
        q3 = [0.3_wp, -0.4_wp, 0.7_wp]
        p3 = [0.2_wp, 0.5_wp, -0.1_wp]
        call check_system(sphere, q3, p3, "sphere")
        q6 = [-0.1_wp, 0.2_wp, 0.7_wp, -0.3_wp, -0.3_wp, 0.5_wp]
        p6 = [0.1_wp, 0.05_wp, -0.2_wp, -0.05_wp, 0.3_wp, -0.1_wp]
        call check_system(linkage, q6, p6, "linkage")
        q2 = [0.6_wp, -0.8_wp]
        p2 = [0.3_wp, 0.2_wp]
        call check_system(planar, q2, p2, "planar")
    contains
        subroutine check_system(sys, q, p, name)
            class(constrained_hamiltonian), intent(in) :: sys
            real(wp), intent(in) :: q(:), p(:)
            character(len=*), intent(in) :: name
            real(wp), dimension(size(q), size(q)) :: hqq, hqp, hpp, dqq, dqp, dpp
            real(wp) :: phi_hess(size(q), size(q), sys%m), phi_diff(size(q), size(q), sys%m)
            real(wp) :: deviation
            call sys%hessian(q, p, hqq, hqp, hpp)
            call difference_hessian(sys, q, p, dqq, dqp, dpp)
            call sys%constraint_hessian(q, phi_hess)
            call difference_constraint_hessian(sys, q, phi_diff)
            deviation = max(maxval(abs(hqq - dqq)), maxval(abs(hqp - dqp)), &
                            maxval(abs(hpp - dpp)), maxval(abs(phi_hess - phi_diff)))
            call check(error, deviation <= hessian_agreement(), name // ": exact and " // &
                "difference Hessians differ by " // real_str(deviation))
        end subroutine check_system
    end subroutine analytic_hessians

    !> The fast path needs far fewer factorisations than the plain path.
    subroutine fast_saves_work(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(spherical_pendulum) :: sys
        real(wp) :: q0(3), p0(3), q(3), p(3)
        integer :: plain_lu, fast_lu
        type(holosym_status_t) :: status
        sys = spherical_pendulum()
        call sys%initial_state(q0, p0)
        call run_variant(sys, q0, p0, 4, 3, 5, run_h, run_steps, 0, q, p, plain_lu, status)
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, "plain run")
        call run_variant(sys, q0, p0, 4, 3, 5, run_h, run_steps, variant_count, q, p, &
                         fast_lu, status)
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, "fast run")
        if (allocated(error)) return
        call check(error, plain_lu >= 3 * run_steps, "plain path: expected >= 3 LU per step, got " &
            // int_str(plain_lu))
        call check(error, 2 * fast_lu < plain_lu, "fast path: " // int_str(fast_lu) // &
            " factorisations against " // int_str(plain_lu) // " on the plain path")
    end subroutine fast_saves_work

    !> stats and step_info count the work; reset_statistics zeroes the counters.
    subroutine statistics_counters(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(spherical_pendulum) :: sys
        type(constrained_integrator) :: integ
        type(step_info_t) :: info
        type(holosym_status_t) :: status
        character(len=:), allocatable :: label
        real(wp) :: q(3), p(3)
        sys = spherical_pendulum()
        call sys%initial_state(q, p)
        integ%structured = .false.
        call integ%init(sys, 2, 1, 3, status)
        call configure(integ, 0, label)
        call integ%step(sys, q, p, run_h, info, status)
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, "step")
        if (allocated(error)) return
        call check(error, integ%stats%steps == 1, "one step counted")
        call check(error, info%lu_factorizations == info%newton_iterations, &
            "full Newton: one LU per iteration")
        call check(error, info%residual_evaluations == info%newton_iterations, &
            "one residual per iteration")
        ! Per iteration: 2G gradients, 1 at the end node; per Jacobian (G + 1) difference
        ! Hessians of 6n gradients, one more gradient; plus 2G for the increments at the
        ! converged x and one for the velocity residual.
        call check(error, info%gradient_evaluations == info%newton_iterations * &
            (2 * 3 + 1 + 4 * 6 * 3 + 1) + 2 * 3 + 1, "gradient count " // &
            int_str(info%gradient_evaluations) // " for " // &
            int_str(info%newton_iterations) // " iterations")
        call check(error, info%hessian_evaluations == info%newton_iterations * (3 + 1 + 2), &
            "hessian count " // int_str(info%hessian_evaluations))
        call check(error, integ%stats%lu_factorizations == info%lu_factorizations, &
            "stats and step_info agree")
        call integ%reset_statistics()
        call check(error, integ%stats%steps == 0 .and. integ%stats%gradient_evaluations == 0, &
            "reset_statistics zeroes the counters")
    end subroutine statistics_counters

    !> An unknown option value fails the step with HOLOSYM_INVALID_ARGUMENT, state unchanged.
    subroutine unknown_options(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(spherical_pendulum) :: sys
        type(constrained_integrator) :: integ
        type(holosym_status_t) :: status
        real(wp) :: q(3), p(3), q0(3)
        sys = spherical_pendulum()
        call sys%initial_state(q, p)
        q0 = q
        integ%structured = .false.
        call integ%init(sys, 2, 1, 3, status)
        integ%linear_solver = "float80"
        call integ%step(sys, q, p, run_h, status=status)
        call check_status_code(error, status%code, HOLOSYM_INVALID_ARGUMENT, "linear_solver")
        call check(error, index(status%message, "float80") > 0, "message names the value")
        call check(error, all(q == q0), "state unchanged")
        integ%linear_solver = "mixed"
        integ%jacobian = "guess"
        call integ%step(sys, q, p, run_h, status=status)
        call check_status_code(error, status%code, HOLOSYM_INVALID_ARGUMENT, "jacobian")
        integ%jacobian = "assembled"
        integ%hessians = "exact"
        call integ%step(sys, q, p, run_h, status=status)
        call check_status_code(error, status%code, HOLOSYM_INVALID_ARGUMENT, "hessians")
        integ%hessians = "user"
        call integ%step(sys, q, p, run_h, status=status)
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, "valid options")
    end subroutine unknown_options

    !> A Jacobian singular in working precision (G = 1 for M = 3) is still reported as
    !! singular with the mixed solver and simplified Newton.
    subroutine mixed_singular(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(spherical_pendulum) :: sys
        type(constrained_integrator) :: integ
        type(holosym_status_t) :: status
        real(wp) :: q(3), p(3)
        sys = spherical_pendulum()
        call sys%initial_state(q, p)
        ! M = N + 2 is singular on the pendulum (its potential is rotationally symmetric).
        integ%structured = .false.
        call integ%init(sys, 3, 1, 4, status)
        integ%linear_solver = "mixed"
        integ%newton%simplified = .true.
        call integ%step(sys, q, p, run_h, status=status)
        call check_status_code(error, status%code, HOLOSYM_SINGULAR_MATRIX, "(3, 1, 4)")
    end subroutine mixed_singular

    !> Simplified Newton with kept factors gives the plain results across a change of h.
    subroutine simplified_step_change(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(spring_linkage) :: sys
        type(constrained_integrator) :: fast, plain
        type(holosym_status_t) :: status
        real(wp) :: qf(6), pf(6), qp(6), pp(6), difference
        integer :: k
        character(len=:), allocatable :: label
        sys = spring_linkage()
        call sys%initial_state(qf, pf)
        qp = qf
        pp = pf
        fast%structured = .false.
        call fast%init(sys, 3, 2, 4, status)
        plain%structured = .false.
        call plain%init(sys, 3, 2, 4, status)
        call configure(fast, variant_count, label)
        call configure(plain, 0, label)
        do k = 1, 6
            call fast%step(sys, qf, pf, run_h / k, status=status)
            call check_status_code(error, status%code, HOLOSYM_SUCCESS, "fast step")
            call plain%step(sys, qp, pp, run_h / k, status=status)
            call check_status_code(error, status%code, HOLOSYM_SUCCESS, "plain step")
            if (allocated(error)) return
        end do
        difference = max(maxval(abs(qf - qp)), maxval(abs(pf - pp)))
        call check(error, difference <= same_results, "states differ by " // real_str(difference))
    end subroutine simplified_step_change

    !> The pendulum at (6,5,7) over T = 10 in `large_steps` steps (h = 5/7) with option
    !! set `variant`.
    subroutine large_step_run(error, integ, variant)
        type(test_error_t), allocatable, intent(inout) :: error
        type(constrained_integrator), intent(inout) :: integ
        integer, intent(in) :: variant
        type(spherical_pendulum) :: sys
        type(holosym_status_t) :: status
        character(len=:), allocatable :: label
        real(wp) :: q(3), p(3)
        sys = spherical_pendulum()
        call sys%initial_state(q, p)
        integ%structured = .false.
        call integ%init(sys, 6, 5, 7, status)
        call configure(integ, variant, label)
        call integ%integrate(sys, q, p, 10.0_wp / large_steps, large_steps, status=status)
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, "(6,5,7), h = 5/7, " // &
            label)
    end subroutine large_step_run

    !> At a large step the Jacobian taken at the extrapolated guess contracts by only ~1e-3
    !! per iteration; simplified Newton refactors at a later iterate when that is predicted
    !! to save evaluations (11 iterations per step without this policy, about 5.6 with it).
    subroutine simplified_refactor_policy(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(constrained_integrator) :: integ
        real(wp) :: per_step
        call large_step_run(error, integ, fast_without_presolve)
        if (allocated(error)) return
        per_step = real(integ%stats%newton_iterations, wp) / large_steps
        call check(error, per_step <= 7, "Newton iterations per step " // real_str(per_step) // &
            " > 7")
        call check(error, integ%stats%lu_factorizations <= 3 * large_steps, "factorisations " // &
            int_str(int(integ%stats%lu_factorizations)) // " > 3 per step")
    end subroutine simplified_refactor_policy

    !> The real64 pre-solve leaves at most three working-precision residuals per step at a
    !! large step (5.6 without it), and only acts in a real128 build with the mixed solver.
    subroutine presolve_saves(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(spherical_pendulum) :: sys
        type(constrained_integrator) :: integ
        type(holosym_status_t) :: status
        character(len=:), allocatable :: label
        real(wp) :: q(3), p(3), per_step
        integer, parameter :: steps = large_steps
        call large_step_run(error, integ, variant_count)
        if (allocated(error)) return
        per_step = real(integ%stats%residual_evaluations, wp) / steps
        if (precision(1.0_wp) > precision(1.0_dp)) then
            call check(error, per_step <= 3, "working-precision residuals per step " // &
                real_str(per_step) // " > 3")
            call check(error, integ%stats%lowered_residual_evaluations >= steps, &
                "lowered residuals: " // int_str(int(integ%stats%lowered_residual_evaluations)))
        else
            call check(error, integ%stats%lowered_residual_evaluations == 0, &
                "the real64 build has nothing to lower")
        end if
        sys = spherical_pendulum()
        call sys%initial_state(q, p)
        integ%structured = .false.
        call integ%init(sys, 6, 5, 7, status)
        call configure(integ, variant_count, label)
        integ%linear_solver = "real128"
        call integ%integrate(sys, q, p, 10.0_wp / steps, steps, status=status)
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, "pre-solve, real128 LU")
        call check(error, integ%stats%lowered_residual_evaluations == 0, &
            "pre-solve acted without the mixed solver")
    end subroutine presolve_saves

    !> linear_increments updates the last iterate's evaluation instead of evaluating at the
    !! solution: 2G gradient calls fewer in each step whose last Newton correction is tiny,
    !! and the same states to 1e-30 (compare_options).
    subroutine linear_increments_save(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(spherical_pendulum) :: sys
        type(constrained_integrator) :: plain, linear
        type(holosym_status_t) :: status
        character(len=:), allocatable :: label
        real(wp) :: q(3), p(3)
        integer(int64) :: saved
        integer, parameter :: gauss_points = 5
        sys = spherical_pendulum()
        call sys%initial_state(q, p)
        plain%structured = .false.
        call plain%init(sys, 4, 3, gauss_points, status)
        call configure(plain, 0, label)
        call plain%integrate(sys, q, p, run_h, run_steps, status=status)
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, "plain")
        call sys%initial_state(q, p)
        linear%structured = .false.
        call linear%init(sys, 4, 3, gauss_points, status)
        call configure(linear, 9, label)
        call linear%integrate(sys, q, p, run_h, run_steps, status=status)
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, label)
        if (allocated(error)) return
        saved = plain%stats%gradient_evaluations - linear%stats%gradient_evaluations
        ! Steps whose Newton ends on a large correction (accepted because the contraction
        ! rate predicts convergence) still evaluate at the solution.
        call check(error, saved >= gauss_points * run_steps .and. &
            mod(saved, 2_int64 * gauss_points) == 0, "gradient calls saved: " // &
            int_str(int(saved)) // ", expected 2G = " // int_str(2 * gauss_points) // &
            " in at least half of the " // int_str(run_steps) // " steps")
    end subroutine linear_increments_save

    !> The default (fast) options solve each step as tightly as the plain path: over 2000
    !! steps the hidden constraint stays within 16 eps (without the safety margin on the
    !! predicted error, about 1 % of the steps ended at 20-50 eps).
    subroutine fast_defaults_constraints(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(spherical_pendulum) :: sys
        type(constrained_integrator) :: integ
        type(step_info_t) :: info
        type(holosym_status_t) :: status
        real(wp) :: q(3), p(3), worst_velocity, worst_position
        integer :: k
        integer, parameter :: steps = 2000
        sys = spherical_pendulum()
        call sys%initial_state(q, p)
        integ%structured = .false.
        call integ%init(sys, 2, 1, 3, status)
        worst_velocity = 0
        worst_position = 0
        do k = 1, steps
            call integ%step(sys, q, p, 0.125_wp, info, status)
            if (.not. status%ok()) exit
            worst_velocity = max(worst_velocity, info%velocity_residual)
            worst_position = max(worst_position, info%constraint_residual)
        end do
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, "step " // int_str(k))
        call check(error, worst_velocity <= 16 * epsilon(1.0_wp), "max |Phi H_p| " // &
            real_str(worst_velocity))
        call check(error, worst_position <= 16 * epsilon(1.0_wp), "max |phi| " // &
            real_str(worst_position))
    end subroutine fast_defaults_constraints

end module test_speed
