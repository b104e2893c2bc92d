!> Tests of ensembles: `run_ensemble` through the façade (results independent of the
!! number of threads, equal to a plain integration, failures recorded per trajectory, bad
!! input refused with the caller's results unchanged, a halting sink), records, and the
!! `holosym ensemble` command (identical files on 1, 2 and 4 threads, a killed run resumed
!! to the uninterrupted run's file, bad input files and outputs refused, nothing
!! overwritten).
module test_ensemble
    use, intrinsic :: iso_fortran_env, only: int64
    use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan
    use holosym, only: wp, spherical_pendulum, spring_linkage, constrained_integrator, &
        holosym_status_t, status_code_name, ensemble_settings_t, ensemble_states_t, &
        ensemble_result_t, ensemble_sink, run_ensemble, perturbed_states, openmp_farm, &
        integrate_member, project_to_manifold, HOLOSYM_SUCCESS, &
        HOLOSYM_OFF_MANIFOLD, HOLOSYM_INVALID_ARGUMENT, HOLOSYM_SIZE_MISMATCH, &
        HOLOSYM_USER_ABORT, HOLOSYM_INVALID_STEP_SIZE, HOLOSYM_NONFINITE_VALUE
    use holosym_internal, only: record_reader_t, put
    use holosym_status_codes, only: int_str
    use holosym_testing, only: test_case_t, new_test, test_error_t, check, overflow_traps
    use holosym_test_commands, only: command_result_t, run_holosym, run_shell, shell_quote, &
        holosym_executable, scratch_path, read_lines, write_lines, file_exists, file_sha256, &
        any_line_contains, text_line_t
    implicit none
    private
    public :: ensemble_tests

    !> A sink that records the order of completion and halts after `halt_after` results.
    type, extends(ensemble_sink) :: counting_sink
        integer :: received = 0
        integer :: halt_after = huge(1)
        integer, allocatable :: ids(:)
    contains
        procedure :: completed => counting_completed
    end type counting_sink

contains

    !> The tests of this suite.
    function ensemble_tests() result(tests)
        type(test_case_t), allocatable :: tests(:)
        tests = [ &
            new_test("threads_1_2_4_give_identical_results", threads_identical), &
            new_test("member_equals_plain_integration", member_equals_plain), &
            new_test("failing_trajectory_recorded_others_go_on", failure_recorded), &
            new_test("bad_input_leaves_results_unchanged", bad_input_unchanged), &
            new_test("sink_halts_the_run", sink_halts), &
            new_test("samples_every_k_steps", samples_taken), &
            new_test("records_round_trip_exactly", records_round_trip), &
            new_test("cli_threads_1_2_4_identical_files", cli_threads_identical), &
            new_test("cli_states_file_with_header_h_and_T", cli_states_file), &
            new_test("cli_samples_one_file_per_trajectory", cli_samples), &
            new_test("cli_samples_identical_on_1_and_2_threads", cli_samples_threads), &
            new_test("cli_failures_identical_on_1_and_2_threads", cli_failures_threads), &
            new_test("cli_kill_and_resume_equals_uninterrupted", cli_kill_and_resume), &
            new_test("cli_bad_states_files_refused", cli_bad_states), &
            new_test("cli_outputs_never_overwritten", cli_outputs_kept), &
            new_test("cli_help_and_usage", cli_help), &
            new_test("cli_one_run_at_a_time_on_a_results_file", cli_one_run_at_a_time), &
            new_test("cli_outputs_naming_one_file_refused", cli_outputs_naming_one_file), &
            new_test("cli_resumed_rows_checked_field_by_field", cli_resumed_rows_checked), &
            new_test("cli_crlf_and_invisible_characters", &
                     cli_line_ends_and_invisible_characters), &
            new_test("cli_ten_digit_ids", cli_ten_digit_ids), &
            new_test("cli_open_failures_name_the_cause", cli_open_failures_name_the_cause), &
            new_test("cli_help_lists_every_system", cli_help_lists_every_system)]
    end function ensemble_tests

    ! ------------------------------------------------------------------ helpers

    subroutine counting_completed(self, result, halt)
        class(counting_sink), intent(inout) :: self
        type(ensemble_result_t), intent(in) :: result
        logical, intent(inout) :: halt
        if (.not. allocated(self%ids)) allocate (self%ids(0))
        self%received = self%received + 1
        self%ids = [self%ids, result%id]
        if (self%received >= self%halt_after) halt = .true.
    end subroutine counting_completed

    !> Twelve perturbed states of the spherical pendulum (to be projected).
    subroutine pendulum_states(states)
        type(ensemble_states_t), intent(out) :: states
        real(wp) :: q0(3), p0(3)
        type(spherical_pendulum) :: sys
        sys = spherical_pendulum()
        call sys%initial_state(q0, p0)
        call perturbed_states(q0, p0, 12, 0.05_wp, 7, states)
    end subroutine pendulum_states

    !> Whether two results are the same to the last bit.
    pure logical function same_result(a, b)
        type(ensemble_result_t), intent(in) :: a, b
        same_result = a%id == b%id .and. a%code == b%code .and. a%steps == b%steps .and. &
            a%steps_done == b%steps_done .and. all(a%q == b%q) .and. all(a%p == b%p) .and. &
            a%max_energy_error == b%max_energy_error .and. &
            a%max_constraint_residual == b%max_constraint_residual .and. &
            a%max_velocity_residual == b%max_velocity_residual .and. &
            a%newton_iterations == b%newton_iterations .and. a%message == b%message
    end function same_result

    !> Run `holosym ensemble` with the words of `line`.
    subroutine ensemble(line, result)
        character(len=*), intent(in) :: line
        type(command_result_t), intent(out) :: result
        call run_holosym("ensemble " // line, result)
    end subroutine ensemble

    !> The error lines of a command, joined, for messages.
    function errors_of(result) result(text)
        type(command_result_t), intent(in) :: result
        character(len=:), allocatable :: text
        integer :: i
        text = "exit " // int_str(result%exit_code) // ":"
        do i = 1, size(result%err)
            text = text // " " // result%err(i)%text
        end do
    end function errors_of

    ! ------------------------------------------------------------------ library

    !> The same ensemble on 1, 2 and 4 threads: every result identical to the last bit.
    subroutine threads_identical(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(spherical_pendulum) :: sys
        type(ensemble_states_t) :: states
        type(ensemble_settings_t) :: settings
        type(ensemble_result_t), allocatable :: results(:, :), run(:)
        type(holosym_status_t) :: status
        type(openmp_farm) :: farm
        integer :: t, k
        integer, parameter :: threads(3) = [1, 2, 4]
        sys = spherical_pendulum()
        call pendulum_states(states)
        settings%project = .true.
        settings%order_m = 3
        settings%order_n = 2
        settings%gauss_points = 4
        settings%final_time = 2
        allocate (results(size(states%id), 3))
        do t = 1, 3
            farm%threads = threads(t)
            call run_ensemble(sys, states, settings, run, status, farm=farm)
            call check(error, status%ok(), "threads " // int_str(threads(t)) // ": " // &
                status%message)
            if (allocated(error)) return
            results(:, t) = run
        end do
        do k = 1, size(states%id)
            call check(error, results(k, 1)%code == HOLOSYM_SUCCESS .and. &
                results(k, 1)%steps_done == 32, "trajectory " // int_str(k) // " completed")
            call check(error, same_result(results(k, 1), results(k, 2)) .and. &
                same_result(results(k, 1), results(k, 3)), "trajectory " // int_str(k) // &
                " is the same on 1, 2 and 4 threads")
        end do
    end subroutine threads_identical

    !> A trajectory of the ensemble is the plain integration of its projected state.
    subroutine member_equals_plain(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(spherical_pendulum) :: sys
        type(ensemble_states_t) :: states
        type(ensemble_settings_t) :: settings
        type(ensemble_result_t) :: result
        type(constrained_integrator) :: integrator
        type(holosym_status_t) :: status
        real(wp) :: q(3), p(3)
        sys = spherical_pendulum()
        call pendulum_states(states)
        settings%project = .true.
        settings%final_time = 1
        call integrate_member(sys, states, settings, 5, result)
        q = states%q(:, 5)
        p = states%p(:, 5)
        call project_to_manifold(sys, q, p, status)
        call integrator%init(sys, 2, 1, 3, status)
        call integrator%integrate(sys, q, p, settings%step_size, 16, status=status)
        call check(error, result%code == 0 .and. result%id == 5 .and. result%steps_done == 16, &
            "member 5 ran 16 steps: " // result%message)
        call check(error, all(result%q == q) .and. all(result%p == p), &
            "the same final state as the plain integration")
        call check(error, result%max_energy_error > 0 .and. &
            result%max_energy_error < 1.0e-6_wp .and. result%newton_iterations > 0, &
            "energy error and Newton iterations recorded")
    end subroutine member_equals_plain

    !> A trajectory with an absurd step fails with its status and message; the others run.
    subroutine failure_recorded(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(spherical_pendulum) :: sys
        type(ensemble_states_t) :: states
        type(ensemble_settings_t) :: settings
        type(ensemble_result_t), allocatable :: results(:)
        type(holosym_status_t) :: status
        sys = spherical_pendulum()
        call pendulum_states(states)
        settings%project = .true.
        settings%final_time = 1
        allocate (states%step_size(size(states%id)), states%final_time(size(states%id)))
        states%step_size = 0.0625_wp
        states%final_time = 1
        states%step_size(3) = 1.0e6_wp
        states%final_time(3) = 1.0e7_wp
        call run_ensemble(sys, states, settings, results, status)
        call check(error, status%ok(), "the run succeeds: " // status%message)
        if (allocated(error)) return
        call check(error, results(3)%code > 0 .and. len(results(3)%message) > 0 .and. &
            results(3)%steps_done < results(3)%steps, "trajectory 3 failed with a message: " &
            // status_code_name(results(3)%code) // " " // results(3)%message)
        call check(error, count(results%code /= 0) == 1 .and. all(results%computed), &
            "the 11 others succeeded")
    end subroutine failure_recorded

    !> Duplicate ids, NaN, off-manifold states, wrong sizes, a bad h: refused with a message
    !! naming the trajectory, results unchanged.
    subroutine bad_input_unchanged(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(spherical_pendulum) :: sys
        type(ensemble_states_t) :: states, bad
        type(ensemble_settings_t) :: settings
        type(ensemble_result_t), allocatable :: results(:)
        type(holosym_status_t) :: status
        real(wp) :: nan
        sys = spherical_pendulum()
        call pendulum_states(states)
        allocate (results(1))
        results(1)%id = -42
        settings%final_time = 1
        ! Off the manifold without `project`.
        call run_ensemble(sys, states, settings, results, status)
        call expect(HOLOSYM_OFF_MANIFOLD, "id 1", "off-manifold states")
        settings%project = .true.
        bad = states
        bad%id(7) = bad%id(2)
        call run_ensemble(sys, bad, settings, results, status)
        call expect(HOLOSYM_INVALID_ARGUMENT, "duplicate id 2", "duplicate ids")
        bad = states
        nan = ieee_value(nan, ieee_quiet_nan)
        bad%p(2, 4) = nan
        call run_ensemble(sys, bad, settings, results, status)
        call expect(HOLOSYM_INVALID_ARGUMENT, "id 4", "NaN")
        bad = states
        bad%q = bad%q(1:2, :)
        call run_ensemble(sys, bad, settings, results, status)
        call expect(HOLOSYM_SIZE_MISMATCH, "3 x 12", "wrong sizes")
        bad = states
        allocate (bad%step_size(12))
        bad%step_size = -1
        call run_ensemble(sys, bad, settings, results, status)
        call expect(HOLOSYM_INVALID_STEP_SIZE, "h = ", "negative h")
        call run_ensemble(sys, states, settings, results, status, skip=[.true.])
        call expect(HOLOSYM_SIZE_MISMATCH, "skip", "skip of the wrong size")
        ! A state on the manifold whose energy overflows (|p| = huge**0.6, tangent): the
        ! Hamiltonian named, not a Newton code.
        if (.not. overflow_traps()) then
            settings%project = .false.
            bad%id = [1]
            bad%q = reshape([1.0_wp, 0.0_wp, 0.0_wp], [3, 1])
            bad%p = reshape([0.0_wp, huge(1.0_wp)**0.6_wp, 0.0_wp], [3, 1])
            if (allocated(bad%step_size)) deallocate (bad%step_size)
            call run_ensemble(sys, bad, settings, results, status)
            call expect(HOLOSYM_NONFINITE_VALUE, "hamiltonian returned NaN or Inf at the " // &
                "start state", "an energy that overflows")
        end if
    contains
        subroutine expect(code, fragment, what)
            integer, intent(in) :: code
            character(len=*), intent(in) :: fragment, what
            call check(error, status%code == code .and. index(status%message, fragment) > 0, &
                what // ": " // status_code_name(status%code) // ": " // status%message)
            call check(error, size(results) == 1 .and. results(1)%id == -42, what // &
                ": results unchanged")
        end subroutine expect
    end subroutine bad_input_unchanged

    !> A sink that halts after 3 results: the run stops with HOLOSYM_USER_ABORT and
    !! `results` is unchanged; skipped trajectories are neither run nor received.
    subroutine sink_halts(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(spherical_pendulum) :: sys
        type(ensemble_states_t) :: states
        type(ensemble_settings_t) :: settings
        type(ensemble_result_t), allocatable :: results(:)
        type(holosym_status_t) :: status
        type(counting_sink) :: sink
        type(openmp_farm) :: farm
        logical :: skip(12)
        sys = spherical_pendulum()
        call pendulum_states(states)
        settings%project = .true.
        settings%final_time = 0.5_wp
        sink%halt_after = 3
        farm%threads = 2
        call run_ensemble(sys, states, settings, results, status, sink, farm)
        call check(error, status%code == HOLOSYM_USER_ABORT .and. sink%received == 3 .and. &
            .not. allocated(results), "halted after 3: " // status%message)
        sink = counting_sink()
        skip = .false.
        skip([2, 5, 11]) = .true.
        call run_ensemble(sys, states, settings, results, status, sink, farm, skip)
        call check(error, status%ok() .and. sink%received == 9, "9 of 12 received")
        if (allocated(error)) return
        call check(error, .not. any(sink%ids == 2 .or. sink%ids == 5 .or. sink%ids == 11) .and. &
            count(results%computed) == 9 .and. .not. results(5)%computed, "skipped ones not run")
    end subroutine sink_halts

    !> every = 4 over 16 steps: samples at t = 0, 4h, ..., 16h, the first the initial state.
    subroutine samples_taken(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(spherical_pendulum) :: sys
        type(ensemble_states_t) :: states
        type(ensemble_settings_t) :: settings
        type(ensemble_result_t) :: result
        sys = spherical_pendulum()
        call pendulum_states(states)
        settings%project = .true.
        settings%final_time = 1
        settings%every = 6
        call integrate_member(sys, states, settings, 1, result)
        call check(error, allocated(result%samples), "samples taken")
        if (allocated(error)) return
        call check(error, size(result%samples, 1) == 10 .and. size(result%samples, 2) == 4, &
            "t = 0, 6h, 12h and the last step 16h: " // int_str(size(result%samples, 2)))
        if (allocated(error)) return
        call check(error, all(result%samples(1, :) == [0, 6, 12, 16] * settings%step_size) &
            .and. all(result%samples(2:4, 4) == result%q) .and. &
            all(result%samples(5:7, 4) == result%p), "times and last state")
    end subroutine samples_taken

    !> Values put into a record come back bit for bit; reading past the end is flagged.
    subroutine records_round_trip(error)
        type(test_error_t), allocatable, intent(out) :: error
        character(len=:), allocatable :: record
        type(record_reader_t) :: reader
        real(wp) :: values(3)
        real(wp), allocatable :: back(:)
        values = [1 / 3.0_wp, -huge(1.0_wp), tiny(1.0_wp)]
        record = ""
        call put(record, 17)
        call put(record, values)
        call put(record, "a, ""quoted"" text")
        call put(record, -5_int64)
        call put(record, .true.)
        call put(record, 0.1_wp)
        call check(error, reader%integer(record) == 17, "integer")
        back = reader%reals(record)
        call check(error, size(back) == 3, "array size")
        if (allocated(error)) return
        call check(error, all(back == values), "reals exact")
        call check(error, reader%text(record) == "a, ""quoted"" text", "text")
        call check(error, reader%integer64(record) == -5_int64, "int64")
        call check(error, reader%logical(record), "logical")
        call check(error, reader%real(record) == 0.1_wp .and. .not. reader%overrun, "real")
        call check(error, reader%integer(record) == 0 .and. reader%overrun, "overrun flagged")
    end subroutine records_round_trip

    ! ------------------------------------------------------------------ command line

    !> The same command on 1, 2 and 4 threads writes the same results file, byte for byte.
    subroutine cli_threads_identical(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(command_result_t) :: result
        character(len=:), allocatable :: digest(:)
        integer :: t
        integer, parameter :: threads(3) = [1, 2, 4]
        character(len=*), parameter :: run = "--system linkage --perturb 10 --scale 0.01 " // &
            "--T 1 --quiet --threads "
        allocate (character(len=64) :: digest(3))
        do t = 1, 3
            call ensemble(run // int_str(threads(t)) // " --output " // &
                scratch_path("ens_t" // int_str(threads(t)) // ".csv"), result)
            call check(error, result%exit_code == 0, "threads " // int_str(threads(t)) // &
                ": " // errors_of(result))
            if (allocated(error)) return
            digest(t) = file_sha256(scratch_path("ens_t" // int_str(threads(t)) // ".csv"))
        end do
        call check(error, len_trim(digest(1)) == 64 .and. digest(1) == digest(2) .and. &
            digest(1) == digest(3), "identical files on 1, 2 and 4 threads")
        call check(error, file_exists(scratch_path("ens_t4.timing.csv")), "timing log beside")
    end subroutine cli_threads_identical

    !> A states file with a header, per-row h and T, comments; rows sorted by id in the
    !! results whatever the input order; the header and columns as documented.
    subroutine cli_states_file(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(command_result_t) :: result
        type(text_line_t), allocatable :: lines(:)
        character(len=:), allocatable :: states, output
        integer :: ios
        states = scratch_path("ens_states.csv")
        output = scratch_path("ens_states_out.csv")
        call write_lines(states, [character(len=120) :: &
            "# three states of the spherical pendulum", &
            "id,q1,q2,q3,p1,p2,p3,h,T", &
            "30,0,0.7071067811865475244008443621048490,0.7071067811865475244008443621048490," &
            // "0.6,0,0,0.125,1", &
            "", &
            "10,0,0.70710678118654752440084436210485,0.70710678118654752440084436210485," &
            // "0.6,0,0,0.0625,0.5", &
            "20,0,0.6,0.8,0.5,0,0,1/8,0"])
        call ensemble("--states " // states // " --output " // output // " --quiet", result)
        call check(error, result%exit_code == 2 .or. result%exit_code == 1, &
            "1/8 is not a CSV number: " // errors_of(result))
        call check(error, any_line_contains(result%err, "ens_states.csv:6"), &
            "the message names file and line: " // errors_of(result))
        call write_lines(states, [character(len=120) :: &
            "# three states of the spherical pendulum", &
            "id,q1,q2,q3,p1,p2,p3,h,T", &
            "30,0,0.7071067811865475244008443621048490,0.7071067811865475244008443621048490," &
            // "0.6,0,0,0.125,1", &
            "", &
            "10,0,0.70710678118654752440084436210485,0.70710678118654752440084436210485," &
            // "0.6,0,0,0.0625,0.5", &
            "20,0,0.6,0.8,0.5,0,0,0.125,0"])
        call ensemble("--states " // states // " --output " // output // " --quiet", result)
        call check(error, result%exit_code == 0, "ran: " // errors_of(result))
        if (allocated(error)) return
        call read_lines(output, lines, ios)
        call check(error, ios == 0 .and. size(lines) == 5, "comment, header and 3 rows")
        if (allocated(error)) return
        call check(error, lines(2)%text == "id,code,steps,steps_done,q1,q2,q3,p1,p2,p3," // &
            "max_energy_error,max_constraint_residual,max_velocity_residual," // &
            "newton_iterations,message", "header: " // lines(2)%text)
        call check(error, lines(3)%text(1:9) == "10,0,8,8," .and. &
            lines(4)%text(1:9) == "20,0,0,0," .and. lines(5)%text(1:9) == "30,0,8,8,", &
            "rows by id with their own h and T: " // lines(3)%text(1:9) // " " // &
            lines(4)%text(1:9) // " " // lines(5)%text(1:9))
        call check(error, lines(3)%text(len(lines(3)%text) - 2:) == ',""', "empty message")
    end subroutine cli_states_file

    !> --samples DIR --every K: one complete file per trajectory, no temporary left.
    subroutine cli_samples(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(command_result_t) :: result
        type(text_line_t), allocatable :: lines(:)
        integer :: ios
        call ensemble("--perturb 3 --T 1 --quiet --output " // scratch_path("ens_s.csv") // &
            " --samples " // scratch_path("ens_samples") // " --every 4", result)
        call check(error, result%exit_code == 0, "ran: " // errors_of(result))
        call read_lines(scratch_path("ens_samples/2.csv"), lines, ios)
        call check(error, ios == 0 .and. size(lines) == 6, "header and t = 0, 4h .. 16h")
        if (allocated(error)) return
        call check(error, lines(1)%text == "t,q1,q2,q3,p1,p2,p3,energy_error," // &
            "constraint_residual,velocity_residual", "samples header")
        call run_shell("ls " // shell_quote(scratch_path("ens_samples")), result)
        call check(error, size(result%out) == 3, "three files, no temporaries: " // &
            int_str(size(result%out)))
    end subroutine cli_samples

    !> The sample files of 24 trajectories written on 2 threads, three times, equal those
    !! written on 1 thread byte for byte (the workers write them while others compute).
    subroutine cli_samples_threads(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(command_result_t) :: result
        character(len=:), allocatable :: reference, name
        integer :: run
        character(len=*), parameter :: common = "--system linkage --perturb 24 " // &
            "--scale 0.01 --M 3 --T 3 --every 8 --quiet --threads "
        do run = 0, 3
            name = "ens_samples_t" // int_str(run)
            call ensemble(common // int_str(min(run + 1, 2)) // " --output " // &
                scratch_path(name // ".csv") // " --samples " // scratch_path(name), result)
            call check(error, result%exit_code == 0, "run " // int_str(run) // ": " // &
                errors_of(result))
            if (allocated(error)) return
            call run_shell("cd " // shell_quote(scratch_path(name)) // " && ls | sort -n | " // &
                "xargs cat | sha256sum", result)
            call check(error, result%exit_code == 0 .and. size(result%out) == 1, "digest")
            if (allocated(error)) return
            if (run == 0) then
                reference = result%out(1)%text
            else
                call check(error, result%out(1)%text == reference, "2 threads, run " // &
                    int_str(run) // ": sample files differ from those on 1 thread")
                if (allocated(error)) return
            end if
        end do
    end subroutine cli_samples_threads

    !> 600 trajectories whose first step fails (h = 50 on the pendulum), on 2 threads three
    !! times: the results file, messages included, equals the one written on 1 thread (the
    !! workers build the same failure message at the same time).
    subroutine cli_failures_threads(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(command_result_t) :: result
        character(len=:), allocatable :: reference, name
        integer :: run
        character(len=*), parameter :: common = "--system pendulum --perturb 600 " // &
            "--scale 0.01 --h 50 --T 100 --quiet --threads "
        do run = 0, 3
            name = scratch_path("ens_failures_t" // int_str(run) // ".csv")
            call ensemble(common // int_str(min(run + 1, 2)) // " --output " // name, result)
            call check(error, result%exit_code == 0, "run " // int_str(run) // ": " // &
                errors_of(result))
            if (allocated(error)) return
            if (run == 0) then
                reference = file_sha256(name)
                call check(error, len(reference) == 64, "digest")
                if (allocated(error)) return
            else
                call check(error, file_sha256(name) == reference, "2 threads, run " // &
                    int_str(run) // ": results differ from those on 1 thread")
                if (allocated(error)) return
            end if
        end do
    end subroutine cli_failures_threads

    !> Kill a run (SIGKILL) after a few rows: every row kept is a row of the uninterrupted
    !! run; --resume computes the rest and leaves the same file, byte for byte.
    subroutine cli_kill_and_resume(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(command_result_t) :: result
        type(text_line_t), allocatable :: lines(:)
        character(len=:), allocatable :: run, full, killed, script
        integer :: ios, kept
        run = shell_quote(holosym_executable()) // " ensemble --perturb 24 --scale 0.05 " // &
            "--M 3 --T 40 --threads 2 --quiet --output "
        full = scratch_path("ens_full.csv")
        killed = scratch_path("ens_killed.csv")
        call run_shell(run // shell_quote(full), result)
        call check(error, result%exit_code == 0, "uninterrupted run: " // errors_of(result))
        if (allocated(error)) return
        script = run // shell_quote(killed) // " & job=$!; " // &
            "for i in $(seq 1 2000); do " // &
            "[ $(tail -n +3 " // shell_quote(killed) // " 2>/dev/null | wc -l) -ge 4 ] && break;" &
            // " sleep 0.01; done; kill -9 $job; wait $job; " // &
            "tail -n +3 " // shell_quote(killed) // " | wc -l"
        call run_shell(script, result)
        call check(error, size(result%out) == 1, "kill script ran: " // errors_of(result))
        if (allocated(error)) return
        read (result%out(1)%text, *, iostat=ios) kept
        call check(error, ios == 0 .and. kept >= 4 .and. kept < 24, "killed with some rows " // &
            "written: " // result%out(1)%text)
        if (allocated(error)) return
        call run_shell("tail -n +3 " // shell_quote(killed) // " | grep -vxFf " // &
            shell_quote(full) // " | wc -l", result)
        call check(error, size(result%out) == 1, "comparison ran")
        if (allocated(error)) return
        call check(error, adjustl(result%out(1)%text) == "0", "every kept row is a row of " // &
            "the uninterrupted run: " // result%out(1)%text // " differ")
        call run_shell(run // shell_quote(killed) // " --resume", result)
        call check(error, result%exit_code == 0, "resumed: " // errors_of(result))
        call check(error, file_sha256(killed) == file_sha256(full), "resumed file equals " // &
            "the uninterrupted run's")
        ! A row cut short by the kill (no end of line) is dropped on resume.
        call read_lines(full, lines, ios)
        call run_shell("head -c -40 " // shell_quote(full) // " > " // shell_quote(killed) // &
            " && " // run // shell_quote(killed) // " --resume", result)
        call check(error, result%exit_code == 0, "resumed after a cut row: " // &
            errors_of(result))
        call check(error, file_sha256(killed) == file_sha256(full), "the cut row recomputed")
    end subroutine cli_kill_and_resume

    !> Malformed states files: each refused with exit 1, a message naming file, line and
    !! what is wrong, and no results file created.
    subroutine cli_bad_states(error)
        type(test_error_t), allocatable, intent(out) :: error
        character(len=*), parameter :: good = "0,0.70710678118654752440084436210485," // &
            "0.70710678118654752440084436210485,0.6,0,0"
        call refused("fields", [character(len=120) :: "1," // good, "2," // good // ",0.1,2"], &
            ":2: expected 7 fields")
        call refused("nan", [character(len=120) :: "1," // good, "2,NaN" // good(2:)], &
            ":2: field 2 must be a finite number")
        call refused("duplicate", [character(len=120) :: "4," // good, "5," // good, &
            "4," // good], ":3: duplicate id 4 (also on line 1)")
        call refused("off", [character(len=120) :: "1," // good, "2,0,0.6,0.9,0.6,0,0"], &
            "id 2): start state violates the constraints")
        call refused("header", [character(len=120) :: "id,x,y,z,p1,p2,p3", "1," // good], &
            ":1: the header must be")
        call refused("id", [character(len=120) :: "one," // good], ":1: field 1 (id)")
        call refused("empty", [character(len=120) :: "# nothing"], "no states")
    contains
        subroutine refused(name, lines, fragment)
            character(len=*), intent(in) :: name, lines(:), fragment
            type(command_result_t) :: result
            character(len=:), allocatable :: states, output
            if (allocated(error)) return
            states = scratch_path("ens_bad_" // name // ".csv")
            output = scratch_path("ens_bad_" // name // "_out.csv")
            call write_lines(states, lines)
            call ensemble("--states " // states // " --output " // output, result)
            call check(error, result%exit_code == 1 .and. any_line_contains(result%err, &
                fragment), name // ": " // errors_of(result))
            call check(error, .not. file_exists(output), name // ": no results file")
        end subroutine refused
    end subroutine cli_bad_states

    !> An existing results file without --resume, a resume with other options, an
    !! unwritable output: refused, every existing file unchanged; --project accepts an
    !! off-manifold state.
    subroutine cli_outputs_kept(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(command_result_t) :: result
        character(len=:), allocatable :: output, digest, states
        output = scratch_path("ens_kept.csv")
        call ensemble("--perturb 4 --T 0.5 --quiet --output " // output, result)
        call check(error, result%exit_code == 0, "first run: " // errors_of(result))
        if (allocated(error)) return
        digest = file_sha256(output)
        call ensemble("--perturb 4 --T 0.5 --quiet --output " // output, result)
        call check(error, result%exit_code == 1 .and. any_line_contains(result%err, &
            "exists; resume the run"), "second run refused: " // errors_of(result))
        call ensemble("--perturb 4 --T 0.25 --quiet --resume --output " // output, result)
        call check(error, result%exit_code == 1 .and. any_line_contains(result%err, &
            "was written by another run"), "resume with another T refused: " // &
            errors_of(result))
        call ensemble("--perturb 5 --T 0.5 --quiet --resume --output " // output, result)
        call check(error, result%exit_code == 1, "resume with other states refused: " // &
            errors_of(result))
        call check(error, file_sha256(output) == digest, "the results file is unchanged")
        call ensemble("--perturb 4 --T 0.5 --quiet --output " // &
            scratch_path("no_such_dir/out.csv"), result)
        call check(error, result%exit_code == 1 .and. any_line_contains(result%err, &
            "cannot create results file"), "unwritable output: " // errors_of(result))
        states = scratch_path("ens_off.csv")
        call write_lines(states, [character(len=40) :: "1,0,0.6,0.8,0.6,0,0.1"])
        call ensemble("--states " // states // " --T 0.5 --quiet --project --output " // &
            scratch_path("ens_projected.csv"), result)
        call check(error, result%exit_code == 0, "--project accepts it: " // errors_of(result))
    end subroutine cli_outputs_kept

    !> --help, and usage errors with exit 2.
    subroutine cli_help(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(command_result_t) :: result
        call ensemble("--help", result)
        call check(error, result%exit_code == 0 .and. any_line_contains(result%out, &
            "--resume"), "help")
        call ensemble("--perturb 3", result)
        call check(error, result%exit_code == 2 .and. any_line_contains(result%err, &
            "--output FILE is required"), "output required: " // errors_of(result))
        call ensemble("--perturb 3 --states x.csv --output y.csv", result)
        call check(error, result%exit_code == 2 .and. any_line_contains(result%err, &
            "exactly one of"), "states or perturb: " // errors_of(result))
        call ensemble("--perturb 0 --output y.csv", result)
        call check(error, result%exit_code == 2, "perturb >= 1: " // errors_of(result))
        call ensemble("--perturb 2 --output y.csv --every 3", result)
        call check(error, result%exit_code == 2 .and. any_line_contains(result%err, &
            "--every needs --samples"), "every needs samples: " // errors_of(result))
    end subroutine cli_help

    ! ------------------------------------------------------------------ files, strictly

    !> A shell command line with `exe` replaced by the quoted executable.
    function with_exe(line) result(command)
        character(len=*), intent(in) :: line
        character(len=:), allocatable :: command
        integer :: at
        command = line
        at = index(command, "EXE")
        do while (at > 0)
            command = command(:at - 1) // shell_quote(holosym_executable()) // command(at + 3:)
            at = index(command, "EXE")
        end do
    end function with_exe

    !> One run at a time on a results file: while another process holds the file's lock
    !! (flock(1), or a run in progress), a second run is refused, naming the file, and
    !! changes nothing; the first run completes its file.
    subroutine cli_one_run_at_a_time(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(command_result_t) :: result
        type(text_line_t), allocatable :: lines(:)
        character(len=:), allocatable :: output, digest, run
        integer :: ios
        output = scratch_path("ens_lock.csv")
        run = "EXE ensemble --perturb 4 --T 0.5 --quiet --resume --output " // &
            shell_quote(output)
        call run_shell("rm -f " // shell_quote(output), result)
        call run_shell(with_exe(run), result)
        call check(error, result%exit_code == 0, "first run: " // errors_of(result))
        if (allocated(error)) return
        digest = file_sha256(output)
        call run_shell(with_exe("flock " // shell_quote(output) // " " // run), result)
        call check(error, result%exit_code == 1 .and. any_line_contains(result%err, &
            "'" // output // "' is in use: another run holds its lock"), &
            "a resume while the lock is held: " // errors_of(result))
        call check(error, file_sha256(output) == digest, "the locked file is unchanged")
        ! A run in progress holds the lock from its start to its end.
        output = scratch_path("ens_lock_live.csv")
        run = "EXE ensemble --system linkage --perturb 24 --T 20 --threads 1 --quiet " // &
            "--output " // shell_quote(output)
        call run_shell("rm -f " // shell_quote(output), result)
        call run_shell(with_exe(run // " & first=$!; while [ ! -s " // shell_quote(output) // &
            " ]; do sleep 0.01; done; " // run // " --resume; echo second=$?; wait $first; " // &
            "echo first=$?"), result)
        call check(error, any_line_contains(result%out, "second=1") .and. &
            any_line_contains(result%err, "another run holds its lock"), &
            "a resume during a run is refused: " // errors_of(result))
        call check(error, any_line_contains(result%out, "first=0"), "the first run " // &
            "completes: " // errors_of(result))
        call read_lines(output, lines, ios)
        call check(error, ios == 0 .and. size(lines) == 2 + 24, "one row per trajectory: " // &
            int_str(size(lines) - 2) // " rows")
    end subroutine cli_one_run_at_a_time

    !> Two of --output, --timing, --samples and --states naming one file (the same text,
    !! another spelling, a link): refused with exit 2 before anything is read or written.
    subroutine cli_outputs_naming_one_file(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(command_result_t) :: result
        character(len=:), allocatable :: states, link, digest
        states = scratch_path("ens_same_states.csv")
        link = scratch_path("ens_same_link.csv")
        call write_lines(states, [character(len=80) :: "1,0,0.6,0.8,0.6,0,0"])
        digest = file_sha256(states)
        call run_shell("rm -f " // shell_quote(link) // " && ln -s " // &
            shell_quote("ens_same_states.csv") // " " // shell_quote(link), result)
        call refused("--perturb 2 --output " // scratch_path("ens_same.csv") // " --timing " &
            // scratch_path("ens_same.csv"), "--timing")
        call refused("--perturb 2 --output " // scratch_path("ens_same.csv") // " --timing " &
            // scratch_path("./ens_same.csv"), "--timing")
        call refused("--states " // states // " --resume --output " // states, "--states")
        call refused("--states " // states // " --resume --output " // link, "--states")
        call refused("--perturb 2 --output " // scratch_path("ens_same.csv") // " --samples " &
            // scratch_path("ens_same.csv"), "--samples")
        call check(error, file_sha256(states) == digest, "the states file is unchanged")
        call check(error, .not. file_exists(scratch_path("ens_same.csv")), "no results file")
    contains
        subroutine refused(line, option)
            character(len=*), intent(in) :: line, option
            call ensemble(line, result)
            call check(error, result%exit_code == 2 .and. any_line_contains(result%err, &
                "name the same file") .and. any_line_contains(result%err, option), &
                line // ": " // errors_of(result))
        end subroutine refused
    end subroutine cli_outputs_naming_one_file

    !> Every field of a resumed row is checked: a status code outside the library's table,
    !! counts out of range, a non-number: refused with the line and the field, the file
    !! unchanged.
    subroutine cli_resumed_rows_checked(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(command_result_t) :: result
        type(text_line_t), allocatable :: lines(:)
        character(len=:), allocatable :: output, args
        integer :: ios
        output = scratch_path("ens_rows.csv")
        args = "--perturb 3 --T 0.5 --quiet --resume --output " // output
        call run_shell("rm -f " // shell_quote(output), result)
        call ensemble(args, result)
        call check(error, result%exit_code == 0, "first run: " // errors_of(result))
        call read_lines(output, lines, ios)
        call check(error, ios == 0 .and. size(lines) == 5, "three rows")
        if (allocated(error)) return
        call refused(2, "77", "field 2 (code) must be a holosym status code")
        call refused(2, "-12", "field 2 (code)")
        call refused(2, "1.5", "field 2 (code)")
        call refused(3, "-1", "field 3 (steps)")
        call refused(4, "9", "field 4 (steps_done) must be an integer from 0 to steps = 8")
        call refused(5, "x", "field 5 (q1) must be a finite number; got 'x'")
        call refused(11, "-1", "field 11 (max_energy_error) must be a number >= 0")
        call refused(14, "-3", "field 14 (newton_iterations)")
        call refused(1, "12345678901", "field 1 (id) must be an integer from -2147483647")
    contains
        subroutine refused(field, value, fragment)
            integer, intent(in) :: field
            character(len=*), intent(in) :: value, fragment
            type(text_line_t), allocatable :: changed(:)
            character(len=:), allocatable :: digest
            character(len=1000) :: texts(5)
            integer :: k
            if (allocated(error)) return
            changed = lines
            changed(3)%text = with_field(lines(3)%text, field, value)
            do k = 1, 5
                texts(k) = changed(k)%text
            end do
            call write_lines(output, texts)
            digest = file_sha256(output)
            call ensemble(args, result)
            call check(error, result%exit_code == 1 .and. any_line_contains(result%err, &
                ":3: " // fragment), "field " // int_str(field) // " = " // value // ": " // &
                errors_of(result))
            call check(error, file_sha256(output) == digest, "field " // int_str(field) // &
                ": the file is unchanged")
        end subroutine refused
    end subroutine cli_resumed_rows_checked

    !> `row` with its comma-separated field k replaced by `value`.
    function with_field(row, k, value) result(changed)
        character(len=*), intent(in) :: row, value
        integer, intent(in) :: k
        character(len=:), allocatable :: changed
        integer :: first, last, j
        first = 1
        do j = 1, k - 1
            first = first + index(row(first:), ",")
        end do
        last = index(row(first:), ",")
        if (last == 0) then
            last = len(row) + 1
        else
            last = first + last - 1
        end if
        changed = row(:first - 1) // value // row(last:)
    end function with_field

    !> CR LF line ends are accepted in states and results files; a carriage return or a
    !! tab inside a value is shown as \r or \t in the message; a resumed file of another
    !! run shows where its first line differs.
    subroutine cli_line_ends_and_invisible_characters(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(command_result_t) :: result
        type(text_line_t), allocatable :: lines(:)
        character(len=:), allocatable :: states, output, good
        integer :: ios
        good = "0,0.70710678118654752440084436210485,0.70710678118654752440084436210485," // &
            "0.6,0,0"
        states = scratch_path("ens_crlf.csv")
        output = scratch_path("ens_crlf_out.csv")
        call run_shell("rm -f " // shell_quote(output) // "; printf 'id,q1,q2,q3,p1,p2,p3" // &
            "\r\n1," // good // "\r\n2," // good // "\r\n' > " // shell_quote(states), result)
        call ensemble("--states " // states // " --T 0.5 --quiet --output " // output, result)
        call read_lines(output, lines, ios)
        call check(error, result%exit_code == 0 .and. ios == 0 .and. size(lines) == 4, &
            "CR LF states: " // errors_of(result))
        if (allocated(error)) return
        call run_shell("sed -i 's/$/\r/' " // shell_quote(output), result)
        call ensemble("--states " // states // " --T 0.5 --quiet --resume --output " // &
            output, result)
        call check(error, result%exit_code == 0, "a CR LF results file resumed: " // &
            errors_of(result))
        call ensemble("--states " // states // " --T 0.25 --quiet --resume --output " // &
            output, result)
        call check(error, result%exit_code == 1 .and. any_line_contains(result%err, &
            "(they differ from character"), "another run's file: " // errors_of(result))
        call run_shell("printf '1,0\r5," // good(3:) // "\n' > " // shell_quote(states), &
                       result)
        call ensemble("--states " // states // " --quiet --output " // &
            scratch_path("ens_cr_inside.csv"), result)
        call check(error, result%exit_code == 1 .and. any_line_contains(result%err, &
            "got '0\r5'"), "a CR inside a field shown as \r: " // errors_of(result))
        call run_shell("printf '1\t," // good // "\n' > " // shell_quote(states), result)
        call ensemble("--states " // states // " --quiet --output " // &
            scratch_path("ens_tab_inside.csv"), result)
        call check(error, result%exit_code == 1 .and. any_line_contains(result%err, &
            "got '1\t'"), "a tab shown as \t: " // errors_of(result))
    end subroutine cli_line_ends_and_invisible_characters

    !> Ids of up to 10 digits (any default integer but -2147483648) in states and results
    !! files, resumed alike; beyond, refused naming the limit.
    subroutine cli_ten_digit_ids(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(command_result_t) :: result
        type(text_line_t), allocatable :: lines(:)
        character(len=:), allocatable :: states, output
        character(len=*), parameter :: good = ",0,0.70710678118654752440084436210485," // &
            "0.70710678118654752440084436210485,0.6,0,0"
        integer :: ios
        states = scratch_path("ens_ids.csv")
        output = scratch_path("ens_ids_out.csv")
        call run_shell("rm -f " // shell_quote(output), result)
        call write_lines(states, [character(len=120) :: "2147483647" // good, &
            "1234567890" // good, "-2147483647" // good])
        call ensemble("--states " // states // " --T 0.5 --quiet --output " // output, result)
        call read_lines(output, lines, ios)
        call check(error, result%exit_code == 0 .and. ios == 0 .and. size(lines) == 5, &
            "10-digit ids: " // errors_of(result))
        if (allocated(error)) return
        call check(error, index(lines(3)%text, "-2147483647,") == 1 .and. &
            index(lines(4)%text, "1234567890,") == 1 .and. &
            index(lines(5)%text, "2147483647,") == 1, "rows sorted by id")
        call ensemble("--states " // states // " --T 0.5 --quiet --resume --output " // &
            output, result)
        call check(error, result%exit_code == 0, "resumed: " // errors_of(result))
        call write_lines(states, [character(len=120) :: "2147483648" // good])
        call ensemble("--states " // states // " --quiet --output " // &
            scratch_path("ens_ids_big.csv"), result)
        call check(error, result%exit_code == 1 .and. any_line_contains(result%err, &
            "must be an integer from -2147483647 to 2147483647; got '2147483648'"), &
            "an 11-digit id: " // errors_of(result))
    end subroutine cli_ten_digit_ids

    !> A file that cannot be opened is named with the system's reason; a start that fails
    !! (the timing log) leaves no results file; a write failure during the run is reported
    !! alone, without the halt that it caused.
    subroutine cli_open_failures_name_the_cause(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(command_result_t) :: result
        character(len=:), allocatable :: output, plain
        output = scratch_path("ens_cause.csv")
        plain = scratch_path("ens_plain_file")
        call run_shell("rm -f " // shell_quote(output) // " && touch " // shell_quote(plain), &
                       result)
        call ensemble("--perturb 2 --T 0.5 --quiet --output " // &
            scratch_path("no_such_dir/x.csv"), result)
        call check(error, result%exit_code == 1 .and. any_line_contains(result%err, &
            "no_such_dir/x.csv': No such file or directory"), "missing directory: " // &
            errors_of(result))
        call ensemble("--perturb 2 --T 0.5 --quiet --output " // plain // "/x.csv", result)
        call check(error, result%exit_code == 1 .and. any_line_contains(result%err, &
            "Not a directory"), "a file as directory: " // errors_of(result))
        call ensemble("--perturb 2 --T 0.5 --quiet --output " // output // " --timing " // &
            scratch_path("no_such_dir/t.csv"), result)
        call check(error, result%exit_code == 1 .and. any_line_contains(result%err, &
            "timing log") .and. any_line_contains(result%err, "No such file or directory"), &
            "timing log in a missing directory: " // errors_of(result))
        call check(error, .not. file_exists(output), "no results file after a failed start")
        call run_shell(with_exe("ulimit -f 2 && EXE ensemble --system linkage --perturb 8 " &
            // "--T 1 --quiet --output " // shell_quote(output)), result)
        call check(error, result%exit_code == 1 .and. any_line_contains(result%err, &
            "File too large") .and. .not. any_line_contains(result%err, "observer") .and. &
            .not. any_line_contains(result%err, "collector"), "a write failure alone: " // &
            errors_of(result))
    end subroutine cli_open_failures_name_the_cause

    !> The help lists the systems that --system accepts, in the words of its message.
    subroutine cli_help_lists_every_system(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(command_result_t) :: result
        character(len=:), allocatable :: choices
        integer :: at, k
        call ensemble("--perturb 2 --output x.csv --system frob", result)
        call check(error, result%exit_code == 2 .and. size(result%err) > 0, &
            "unknown system: " // errors_of(result))
        if (allocated(error)) return
        at = index(result%err(1)%text, "choose ")
        call check(error, at > 0, "the message lists the systems: " // errors_of(result))
        if (allocated(error)) return
        choices = result%err(1)%text(at + len("choose "):)
        call ensemble("--help", result)
        call check(error, any_line_contains(result%out, choices), "the help lists '" // &
            choices // "'")
        do k = 1, size(result%out)
            if (index(result%out(k)%text, "--model FILE") > 0) exit
        end do
        call check(error, k <= size(result%out), "the help names --model")
    end subroutine cli_help_lists_every_system

end module test_ensemble
