!> Tests of `init_for_accuracy` and `holosym simulate --accuracy`: the global error at
!! T = 10 reached on the three paper systems, the double pendulum and the magnetic sphere
!! stays within 10 times the request from 1e-8 to 1e-30 (real128; 1e-6 to 1e-10 in
!! real64); bad requests are refused with the caller's data unchanged.
module test_accuracy
    use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan, ieee_positive_inf
    use holosym_kinds, only: wp, wp_is_double
    use holosym_status_codes, only: holosym_status_t, real_str, int_str, HOLOSYM_SUCCESS, &
        HOLOSYM_INVALID_ARGUMENT, HOLOSYM_SIZE_MISMATCH
    use holosym_problem, only: constrained_hamiltonian
    use holosym_integrator, only: constrained_integrator
    use holosym_accuracy, only: accuracy_plan_t, init_for_accuracy, accuracy_floor
    use holosym_test_systems, only: builtin_system
    use holosym_study_systems, only: reference_state
    use holosym_test_commands, only: text_line_t, read_lines, command_result_t, run_holosym, &
        any_line_contains, scratch_path, reset_scratch
    use test_models, only: reference_values
    use holosym_testing, only: test_case_t, new_test, test_error_t, check, check_status_code
    implicit none
    private
    public :: accuracy_tests

    real(wp), parameter :: span = 10
    character(len=*), parameter :: reference_file = "test/data/model_reference.csv"

contains

    !> The tests of this suite.
    function accuracy_tests() result(tests)
        type(test_case_t), allocatable :: tests(:)
        tests = [ &
            new_test("paper_systems_within_10x", paper_systems), &
            new_test("independent_references_within_10x", independent_systems), &
            new_test("bad_requests_refused", bad_requests), &
            new_test("cli_prints_its_choice", cli_accuracy), &
            new_test("ensemble_planned_from_the_start", ensemble_accuracy) &
        ]
    end function accuracy_tests

    !> The requests of this build: 1e-8 .. 1e-30 in real128, 1e-6 .. 1e-10 in real64 (a run
    !! of a thousand real64 steps has round-off of some 1e-12).
    function requests() result(list)
        real(wp), allocatable :: list(:)
        if (wp_is_double) then
            list = [1.0e-6_wp, 1.0e-8_wp, 1.0e-10_wp]
        else
            list = [1.0e-8_wp, 1.0e-14_wp, 1.0e-20_wp, 1.0e-26_wp, 1.0e-30_wp]
        end if
    end function requests

    !> The spherical pendulum, the spring-linkage and the planar pendulum against a
    !! reference of their own: 1280 steps of (8, 7, 9) (order 16, h = 1/128), checked
    !! against 640 steps to agree within 1e-32 (real64: 640 steps of (6, 5, 7) against 320,
    !! within 1e5 epsilon, its round-off over the run), far below every request.
    subroutine paper_systems(error)
        type(test_error_t), allocatable, intent(out) :: error
        character(len=*), parameter :: names(3) = [character(len=8) :: "pendulum", &
            "linkage", "planar"]
        class(constrained_hamiltonian), allocatable :: sys
        type(holosym_status_t) :: status
        real(wp), allocatable :: q(:), p(:), q_ref(:), p_ref(:)
        real(wp) :: difference
        integer :: s, reference_steps
        ! real64: steps of 1/64 at order 12 (finer ones stall Newton at round-off).
        reference_steps = merge(640, 1280, wp_is_double)
        do s = 1, size(names)
            call builtin_system(trim(names(s)), sys, q, p)
            call reference_state(sys, q, p, span, reference_steps, q_ref, p_ref, difference, &
                                 status)
            call check(error, status%ok(), "reference run: " // status%message)
            if (allocated(error)) return
            call check(error, difference <= max(1.0e-32_wp, 1.0e5_wp * epsilon(1.0_wp)), &
                trim(names(s)) // ": the reference is not converged: " // &
                int_str(reference_steps) // " steps and half as many differ by " // &
                real_str(difference))
            if (allocated(error)) return
            call within_request(sys, trim(names(s)), q, p, q_ref, p_ref, error)
            if (allocated(error)) return
        end do
    end subroutine paper_systems

    !> The double pendulum and the magnetic sphere against the independent 50-digit
    !! references at T = 10 (test/data/model_reference.csv).
    subroutine independent_systems(error)
        type(test_error_t), allocatable, intent(out) :: error
        character(len=*), parameter :: names(2) = [character(len=8) :: "double", "magnetic"]
        class(constrained_hamiltonian), allocatable :: sys
        type(text_line_t), allocatable :: lines(:)
        real(wp), allocatable :: q(:), p(:), q_ref(:), p_ref(:)
        integer :: s, ios
        call read_lines(reference_file, lines, ios)
        call check(error, ios == 0, "cannot read " // reference_file)
        if (allocated(error)) return
        do s = 1, size(names)
            call builtin_system(trim(names(s)), sys, q, p)
            allocate (q_ref(sys%n), p_ref(sys%n))
            call reference_values(lines, trim(names(s)), "q0", q, error)
            call reference_values(lines, trim(names(s)), "p0", p, error)
            call reference_values(lines, trim(names(s)), "qT", q_ref, error)
            call reference_values(lines, trim(names(s)), "pT", p_ref, error)
            if (allocated(error)) return
            call within_request(sys, trim(names(s)), q, p, q_ref, p_ref, error)
            if (allocated(error)) return
            deallocate (q_ref, p_ref)
        end do
    end subroutine independent_systems

    !> For every request: plan, run to T, and check the error at T (at most 10 times the
    !! request), the plan's own estimate (within 10 times the request too), that the run
    !! reaches T exactly, and that the start state was not changed by the pilot.
    subroutine within_request(sys, name, q0, p0, q_ref, p_ref, error)
        class(constrained_hamiltonian), intent(in) :: sys
        character(len=*), intent(in) :: name
        real(wp), intent(in) :: q0(:), p0(:), q_ref(:), p_ref(:)
        type(test_error_t), allocatable, intent(inout) :: error
        type(constrained_integrator) :: integ
        type(accuracy_plan_t) :: plan
        type(holosym_status_t) :: status
        real(wp), allocatable :: list(:), q(:), p(:)
        real(wp) :: achieved
        integer :: k
        list = requests()
        do k = 1, size(list)
            q = q0
            p = p0
            call init_for_accuracy(integ, sys, q, p, list(k), span, plan, status)
            call check(error, status%ok(), name // ": plan for " // real_str(list(k)) // &
                ": " // status%message)
            if (allocated(error)) return
            call check(error, all(q == q0) .and. all(p == p0), name // ": the pilot " // &
                "changed the start state")
            call check(error, plan%steps * plan%h == span .or. &
                abs(plan%steps * plan%h - span) <= 4 * epsilon(1.0_wp) * span, name // &
                ": steps * h /= T")
            call integ%integrate(sys, q, p, plan%h, plan%steps, status=status)
            call check(error, status%ok(), name // ": run for " // real_str(list(k)) // &
                ": " // status%message)
            if (allocated(error)) return
            achieved = max(maxval(abs(q - q_ref)), maxval(abs(p - p_ref)))
            call check(error, achieved <= 10 * list(k), name // ": asked " // &
                real_str(list(k)) // ", reached " // real_str(achieved) // " with (M, N, G)" &
                // " = (" // int_str(plan%order_m) // ", " // int_str(plan%order_n) // ", " // &
                int_str(plan%gauss_points) // "), " // int_str(plan%steps) // " steps")
            call check(error, plan%estimate <= 10 * list(k) .and. plan%estimate > 0, name // &
                ": estimate " // real_str(plan%estimate) // " for " // real_str(list(k)))
            if (allocated(error)) return
        end do
    end subroutine within_request

    !> A tolerance outside [accuracy_floor, 1) or not finite, T <= 0 or not finite, a plan
    !! of more steps than `integrate` counts, and states of the wrong size are refused,
    !! naming the argument, with q, p and the integrator unchanged.
    subroutine bad_requests(error)
        type(test_error_t), allocatable, intent(out) :: error
        class(constrained_hamiltonian), allocatable :: sys
        type(constrained_integrator) :: integ
        type(accuracy_plan_t) :: plan
        type(holosym_status_t) :: status
        real(wp), allocatable :: q(:), p(:), q0(:), p0(:)
        real(wp) :: nan, bad_tolerances(5), bad_spans(4)
        integer :: k, m_kept, n_kept, g_kept
        call builtin_system("pendulum", sys, q, p)
        q0 = q
        p0 = p
        nan = ieee_value(1.0_wp, ieee_quiet_nan)
        bad_tolerances = [0.0_wp, -1.0e-10_wp, 1.0_wp, accuracy_floor(1.0_wp) / 2, nan]
        do k = 1, size(bad_tolerances)
            call init_for_accuracy(integ, sys, q, p, bad_tolerances(k), span, plan, status)
            call check_status_code(error, status%code, HOLOSYM_INVALID_ARGUMENT, &
                "tolerance " // real_str(bad_tolerances(k)))
            call check(error, index(status%message, "tolerance") > 0, "message: " // &
                status%message)
        end do
        bad_spans = [0.0_wp, -1.0_wp, nan, ieee_value(1.0_wp, ieee_positive_inf)]
        do k = 1, size(bad_spans)
            call init_for_accuracy(integ, sys, q, p, 1.0e-10_wp, bad_spans(k), plan, status)
            call check_status_code(error, status%code, HOLOSYM_INVALID_ARGUMENT, &
                "T " // real_str(bad_spans(k)))
        end do
        ! A plan beyond the step counter: refused after the pilot, saying how many steps;
        ! the caller's integrator keeps its set-up and settings.
        integ%newton%tolerance = 1.0e-20_wp
        call integ%init(sys, 2, 1, 3, status)
        call init_for_accuracy(integ, sys, q, p, 100 * accuracy_floor(1.0_wp), 1.0e12_wp, &
                               plan, status)
        call check_status_code(error, status%code, HOLOSYM_INVALID_ARGUMENT, "T = 1e12")
        call check(error, index(status%message, "steps") > 0, "message: " // status%message)
        call integ%orders(m_kept, n_kept, g_kept)
        call check(error, integ%newton%tolerance == 1.0e-20_wp .and. m_kept == 2 .and. &
            n_kept == 1 .and. g_kept == 3, "a failed plan changed the integrator")
        call init_for_accuracy(integ, sys, q(1:2), p, 1.0e-10_wp, span, plan, status)
        call check_status_code(error, status%code, HOLOSYM_SIZE_MISMATCH, "size of q")
        call check(error, all(q == q0) .and. all(p == p0), "state changed by refusals")
    end subroutine bad_requests

    !> `holosym simulate --accuracy 1e-10 --T 10` prints its choice and estimate and reaches
    !! T; --accuracy with --M or --steps is refused (exit 2), and a request outside (0, 1)
    !! too.
    subroutine cli_accuracy(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(command_result_t) :: run
        call run_holosym("simulate --system magnetic --accuracy 1e-10 --T 10 --every 100000", &
                         run)
        call check(error, run%exit_code == 0, "exit " // int_str(run%exit_code))
        call check(error, any_line_contains(run%err, "--accuracy") .and. &
            any_line_contains(run%err, "estimated error") .and. &
            any_line_contains(run%err, "(M, N, G) = ("), "choice not printed")
        if (allocated(error)) return
        call check(error, index(run%out(size(run%out))%text, "E+0001,") > 0, &
            "the last row is not at t = 10: " // run%out(size(run%out))%text(1:40))
        call run_holosym("simulate --accuracy 1e-10 --M 4", run)
        call check(error, run%exit_code == 2 .and. any_line_contains(run%err, "--M"), &
            "--accuracy with --M: exit " // int_str(run%exit_code))
        call run_holosym("simulate --accuracy 1e-10 --steps 10", run)
        call check(error, run%exit_code == 2 .and. any_line_contains(run%err, "--steps"), &
            "--accuracy with --steps: exit " // int_str(run%exit_code))
        call run_holosym("simulate --accuracy 2", run)
        call check(error, run%exit_code == 2 .and. any_line_contains(run%err, "(0, 1)"), &
            "--accuracy 2: exit " // int_str(run%exit_code))
    end subroutine cli_accuracy

    !> `holosym ensemble --accuracy 1e-20 --T 10` (1e-10 in real64) plans from the system's
    !! start, says so,
    !! records the request in the results file's first line and runs every trajectory;
    !! --accuracy with --h is refused.
    subroutine ensemble_accuracy(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(command_result_t) :: run
        type(text_line_t), allocatable :: lines(:)
        character(len=:), allocatable :: dir
        integer :: ios
        call check(error, reset_scratch(), "cannot make the scratch directory")
        if (allocated(error)) return
        dir = scratch_path("")
        call run_holosym("ensemble --system pendulum --perturb 3 --scale 0.01 --accuracy " &
            // trim(merge("1e-10", "1e-20", wp_is_double)) // " --T 10 --output " // dir // &
            "/runs.csv", run)
        call check(error, run%exit_code == 0, "exit " // int_str(run%exit_code))
        call check(error, any_line_contains(run%err, "--accuracy") .and. &
            any_line_contains(run%err, "estimated error"), "plan not printed")
        call read_lines(dir // "/runs.csv", lines, ios)
        call check(error, ios == 0, "no results file")
        if (allocated(error)) return
        call check(error, index(lines(1)%text, " accuracy=") > 0 .and. &
            index(lines(1)%text, merge(" M=6 ", " M=8 ", wp_is_double)) > 0, &
            "first line: " // lines(1)%text)
        call check(error, size(lines) == 5, int_str(size(lines)) // " lines, expected 5")
        call run_holosym("ensemble --system pendulum --perturb 3 --accuracy 1e-20 --h 0.1 " &
            // "--output " // dir // "/other.csv", run)
        call check(error, run%exit_code == 2 .and. any_line_contains(run%err, "--h"), &
            "--accuracy with --h: exit " // int_str(run%exit_code))
    end subroutine ensemble_accuracy

end module test_accuracy
