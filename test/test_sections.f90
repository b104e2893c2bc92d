!> Tests of sections and Poincare runs: `make_section` over q1..qn, p1..pn and over a
!! model's own names, the crossings recorded by an ensemble (times against the elliptic
!! integral K computed independently in test_events, the same on one and two threads),
!! the crossing limit, bad sections, and `holosym poincare` run as a user runs it.
module test_sections
    use holosym_kinds, only: wp
    use holosym_status_codes, only: holosym_status_t, real_str, int_str, HOLOSYM_SUCCESS, &
        HOLOSYM_INVALID_ARGUMENT, HOLOSYM_INVALID_MODEL
    use holosym_problem, only: constrained_hamiltonian
    use holosym_models, only: planar_pendulum
    use holosym_events, only: EVENT_ANY, EVENT_RISING, EVENT_FALLING
    use holosym_sections, only: section_t, make_section
    use holosym_formula_model, only: formula_model, model_from_text
    use holosym_task_farm, only: openmp_farm
    use holosym_ensemble, only: ensemble_settings_t, ensemble_states_t, ensemble_result_t, &
        run_ensemble, check_ensemble, perturbed_states
    use holosym_test_commands, only: command_result_t, text_line_t, run_holosym, &
        read_lines, scratch_path, write_lines, any_line_contains
    use holosym_testing, only: test_case_t, new_test, test_error_t, check, check_status_code, &
        split_field
    use test_events, only: elliptic_k, pendulum_text
    implicit none
    private
    public :: sections_tests

    real(wp), parameter :: eps = epsilon(1.0_wp)
    !> The scheme's accuracy at (8, 7, 9), h = 1/16 over a few periods, with room.
    real(wp), parameter :: scheme_accuracy = max(1.0e-29_wp, 1.0e4_wp * eps)

contains

    !> The tests of this suite.
    function sections_tests() result(tests)
        type(test_case_t), allocatable :: tests(:)
        tests = [ &
            new_test("crossings_match_elliptic_reference", elliptic_crossings), &
            new_test("model_names_and_q_p_names_agree", model_names), &
            new_test("same_crossings_on_1_and_2_threads", threads_agree), &
            new_test("crossing_limit_ends_each_orbit", crossing_limit), &
            new_test("bad_sections_refused", bad_sections), &
            new_test("cli_poincare_spherical_pendulum", cli_poincare), &
            new_test("cli_poincare_refusals", cli_refusals) &
        ]
    end function sections_tests

    !> The planar pendulum released at 1 rad crosses x = 0 at (2j + 1) K: falling at K and
    !! 5K, rising at 3K (T = 6: K and 3K either way; K alone falling).
    subroutine elliptic_crossings(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(ensemble_result_t), allocatable :: results(:)
        real(wp) :: quarter
        integer :: j, direction
        quarter = elliptic_k(sin(0.5_wp))
        do direction = EVENT_FALLING, EVENT_RISING
            call run_planar("q1", direction, 0, 1, results, error)
            if (allocated(error)) return
            associate (c => results(1)%crossings)
                call check(error, size(c, 2) == merge(2, 1, direction == EVENT_ANY), &
                    int_str(size(c, 2)) // " crossings in direction " // int_str(direction))
                if (allocated(error)) return
                do j = 1, size(c, 2)
                    call check(error, abs(c(1, j) - (2 * j - 1 + merge(2, 0, &
                        direction == EVENT_RISING)) * quarter) <= scheme_accuracy .and. &
                        abs(c(2, j)) <= scheme_accuracy .and. &
                        abs(c(2, j)**2 + c(3, j)**2 - 1) <= 64 * eps, "crossing " // &
                        int_str(j) // " at t = " // real_str(c(1, j)) // ", x = " // &
                        real_str(c(2, j)))
                    if (allocated(error)) return
                end do
            end associate
        end do
    end subroutine elliptic_crossings

    !> On the pendulum's model (with an `event` of its own), a section over the model's
    !! names (x, px) and the same over q1, p1 give the crossings of the built-in twin (to
    !! the twins' round-off).
    subroutine model_names(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(ensemble_result_t), allocatable :: builtin(:), by_name(:), by_index(:)
        type(formula_model) :: model
        type(holosym_status_t) :: status
        call run_planar("q1 + p1/10", EVENT_ANY, 0, 1, builtin, error)
        if (allocated(error)) return
        ! The model's own event comes before the section's: the section is still its own.
        call model_from_text(pendulum_text() // new_line("a") // "event low: y + 0.9", &
                             model, status)
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, status%message)
        if (allocated(error)) return
        call run_system(model, "x + px/10", EVENT_ANY, 0, 1, by_name, error)
        if (allocated(error)) return
        call run_system(model, "q1 + p1/10", EVENT_ANY, 0, 1, by_index, error)
        if (allocated(error)) return
        call check(error, size(builtin(1)%crossings, 2) >= 1 .and. &
            all(shape(by_name(1)%crossings) == shape(builtin(1)%crossings)) .and. &
            all(shape(by_index(1)%crossings) == shape(builtin(1)%crossings)), &
            "crossings: " // int_str(size(builtin(1)%crossings, 2)) // ", " // &
            int_str(size(by_name(1)%crossings, 2)) // ", " // &
            int_str(size(by_index(1)%crossings, 2)))
        if (allocated(error)) return
        call check(error, maxval(abs(by_name(1)%crossings - builtin(1)%crossings)) <= &
            scheme_accuracy .and. all(by_index(1)%crossings == by_name(1)%crossings), &
            "model and built-in differ by " // &
            real_str(maxval(abs(by_name(1)%crossings - builtin(1)%crossings))))
        if (allocated(error)) return
        ! A model's own `let q1` is its q1 (the section uses the model's names alone).
        call model_from_text(pendulum_text() // new_line("a") // "let q1 = x", model, status)
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, status%message)
        if (allocated(error)) return
        call run_system(model, "q1 + px/10", EVENT_ANY, 0, 1, by_index, error)
        if (allocated(error)) return
        call check(error, all(shape(by_index(1)%crossings) == shape(by_name(1)%crossings)), &
            "a let named q1: " // int_str(size(by_index(1)%crossings, 2)) // " crossings")
        if (allocated(error)) return
        call check(error, all(by_index(1)%crossings == by_name(1)%crossings), &
            "a let named q1: other crossings")
    end subroutine model_names

    !> Eight perturbed orbits: the crossings are bit for bit the same on one and on two
    !! threads (each orbit depends on its own start only).
    subroutine threads_agree(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(ensemble_result_t), allocatable :: one(:), two(:)
        integer :: k
        call run_planar("q1", EVENT_RISING, 0, 1, one, error, orbits=8)
        if (allocated(error)) return
        call run_planar("q1", EVENT_RISING, 0, 2, two, error, orbits=8)
        if (allocated(error)) return
        do k = 1, 8
            call check(error, size(one(k)%crossings, 2) == 1 .and. &
                all(shape(one(k)%crossings) == shape(two(k)%crossings)), "orbit " // &
                int_str(k) // ": " // int_str(size(one(k)%crossings, 2)) // " crossings")
            if (allocated(error)) return
            call check(error, all(one(k)%crossings == two(k)%crossings), "orbit " // &
                int_str(k) // " differs between 1 and 2 threads")
            if (allocated(error)) return
        end do
    end subroutine threads_agree

    !> crossing_limit = 1 ends the orbit at its first crossing (steps done < steps);
    !! a negative limit is refused by check_ensemble; a section never crossed gives no
    !! crossings and success.
    subroutine crossing_limit(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(ensemble_result_t), allocatable :: results(:)
        type(planar_pendulum), target :: sys
        type(ensemble_states_t) :: states
        type(ensemble_settings_t) :: settings
        type(section_t), target :: section
        type(holosym_status_t) :: status
        call run_planar("q1", EVENT_ANY, 1, 1, results, error)
        if (allocated(error)) return
        call check(error, size(results(1)%crossings, 2) == 1 .and. &
            results(1)%steps_done < results(1)%steps .and. results(1)%code == &
            HOLOSYM_SUCCESS, int_str(size(results(1)%crossings, 2)) // " crossings, " // &
            int_str(results(1)%steps_done) // " of " // int_str(results(1)%steps) // " steps")
        if (allocated(error)) return
        call run_planar("q1 - 5", EVENT_ANY, 0, 1, results, error)
        if (allocated(error)) return
        call check(error, size(results(1)%crossings, 2) == 0 .and. &
            results(1)%steps_done == results(1)%steps, "a section never crossed")
        if (allocated(error)) return
        sys = planar_pendulum()
        call planar_states(sys, 1, states)
        call make_section(sys, "q1", EVENT_ANY, section, status)
        settings%section => section
        settings%crossing_limit = -1
        call check_ensemble(sys, states, settings, status)
        call check_status_code(error, status%code, HOLOSYM_INVALID_ARGUMENT, status%message)
        if (allocated(error)) return
        call check(error, index(status%message, "crossing_limit must be >= 0") > 0, &
            status%message)
    end subroutine crossing_limit

    !> Bad sections: a direction other than -1, 0, 1, an empty expression, an unknown
    !! name, a syntax error and a constant are refused with the column in the expression.
    subroutine bad_sections(error)
        type(test_error_t), allocatable, intent(out) :: error
        character(len=*), parameter :: bad(*) = [character(len=12) :: "q1 + z", &
            "q1 +", "1 + 2", "x"]
        character(len=*), parameter :: said(*) = [character(len=48) :: &
            "section 'q1 + z': column 6: unknown name 'z'", &
            "section 'q1 +': column 5:", "section '1 + 2': column 1:", &
            "section 'x': column 1: unknown name 'x'"]
        type(planar_pendulum) :: sys
        type(section_t) :: section
        type(holosym_status_t) :: status
        integer :: k
        sys = planar_pendulum()
        call make_section(sys, "q1", 2, section, status)
        call check_status_code(error, status%code, HOLOSYM_INVALID_ARGUMENT, status%message)
        if (allocated(error)) return
        call make_section(sys, "  ", EVENT_ANY, section, status)
        call check_status_code(error, status%code, HOLOSYM_INVALID_ARGUMENT, status%message)
        if (allocated(error)) return
        do k = 1, size(bad)
            call make_section(sys, trim(bad(k)), EVENT_ANY, section, status)
            call check_status_code(error, status%code, HOLOSYM_INVALID_MODEL, trim(bad(k)))
            if (allocated(error)) return
            call check(error, index(status%message, trim(said(k))) == 1, trim(bad(k)) // &
                ": " // status%message)
            if (allocated(error)) return
        end do
    end subroutine bad_sections

    !> The example of `holosym poincare --help`: the spherical pendulum's crossings of
    !! q3 = 0.75 rising, each on the section and on the sphere to round-off, at times
    !! increasing; written in the order of the orbits' ids for --perturb 3.
    subroutine cli_poincare(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(command_result_t) :: a
        type(text_line_t), allocatable :: rows(:)
        character(len=:), allocatable :: file, field
        real(wp) :: x(8), t_last
        integer :: ios, j, i, orbit, last_orbit
        file = scratch_path("poincare.csv")
        call run_holosym([character(len=256) :: "poincare", "--system", "pendulum", &
            "--section", "q3 - 0.75", "--direction", "rising", "--T", "10", "--M", "8", &
            "--h", "1/8", "--perturb", "3", "--scale", "0.01", "--output", file], a)
        call check(error, len(a%failure) == 0 .and. a%exit_code == 0, "exit " // &
            int_str(a%exit_code) // " " // a%failure)
        if (allocated(error)) return
        call read_lines(file, rows, ios)
        call check(error, ios == 0 .and. size(rows) >= 7, int_str(size(rows)) // " lines")
        if (allocated(error)) return
        call check(error, rows(1)%text == "orbit,t,q1,q2,q3,p1,p2,p3", rows(1)%text)
        if (allocated(error)) return
        last_orbit = 0
        t_last = 0
        do j = 2, size(rows)
            field = split_field(rows(j)%text, 1, ",")
            read (field, *, iostat=ios) orbit
            do i = 1, 7
                field = split_field(rows(j)%text, i + 1, ",")
                if (ios == 0) read (field, *, iostat=ios) x(i)
            end do
            call check(error, ios == 0 .and. orbit >= last_orbit .and. &
                abs(x(4) - 0.75_wp) <= 64 * eps .and. abs(sum(x(2:4)**2) - 1) <= 64 * eps &
                .and. (orbit > last_orbit .or. x(1) > t_last) .and. x(7) > 0, &
                "row " // rows(j)%text)
            if (allocated(error)) return
            last_orbit = orbit
            t_last = x(1)
        end do
        call check(error, last_orbit == 3 .and. any_line_contains(a%err, &
            "holosym poincare: " // int_str(size(rows) - 1) // " crossings of 3 orbits"), &
            "the summary line")
    end subroutine cli_poincare

    !> A section never crossed: exit 1 and why; no --section, a bad direction: exit 2
    !! with the option named; a bad expression: exit 1 with its column; a model's own
    !! names work, and --count ends each orbit at that many crossings.
    subroutine cli_refusals(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(command_result_t) :: a
        character(len=:), allocatable :: model
        model = scratch_path("section_model.hsm")
        call run_holosym([character(len=16) :: "poincare", "--system", "planar", &
            "--section", "q2 + 2", "--T", "2"], a)
        call check(error, a%exit_code == 1 .and. any_line_contains(a%err, "the section " // &
            "q2 + 2 = 0 was not crossed rising by any orbit up to T = 2"), "never crossed: " &
            // "exit " // int_str(a%exit_code))
        if (allocated(error)) return
        call run_holosym("poincare --system planar --T 2", a)
        call check(error, a%exit_code == 2 .and. any_line_contains(a%err, &
            "option --section EXPR is required"), "no --section: exit " // int_str(a%exit_code))
        if (allocated(error)) return
        call run_holosym("poincare --system planar --section q1 --states " // model // &
            " --output " // model, a)
        call check(error, a%exit_code == 2 .and. any_line_contains(a%err, "options " // &
            "--states and --output name the same file"), "--states = --output: exit " // &
            int_str(a%exit_code))
        if (allocated(error)) return
        call run_holosym("poincare --system planar --section q1 --direction up", a)
        call check(error, a%exit_code == 2 .and. any_line_contains(a%err, &
            "option --direction must be rising, falling or any; got 'up'"), "bad direction")
        if (allocated(error)) return
        call run_holosym("poincare --system planar --section q1+w", a)
        call check(error, a%exit_code == 1 .and. any_line_contains(a%err, &
            "section 'q1+w': column 4: unknown name 'w'"), "bad expression: exit " // &
            int_str(a%exit_code))
        if (allocated(error)) return
        model = scratch_path("section_model.hsm")
        call write_lines(model, [character(len=60) :: "coordinates x y", "momenta px py", &
            "hamiltonian (px^2 + py^2)/2 + y", "constraint x^2 + y^2 - 1", &
            "initial x = sin(1), y = -cos(1)"])
        call run_holosym("poincare --model " // model // " --section x --direction any " // &
            "--T 6 --M 8 --h 1/16 --quiet", a)
        call check(error, a%exit_code == 0 .and. size(a%out) == 3, "model names: exit " // &
            int_str(a%exit_code) // ", " // int_str(size(a%out)) // " lines")
        if (allocated(error)) return
        call run_holosym("poincare --model " // model // " --section x --direction any " // &
            "--T 6 --M 8 --h 1/16 --quiet --count 1", a)
        call check(error, a%exit_code == 0 .and. size(a%out) == 2, "--count 1: exit " // &
            int_str(a%exit_code) // ", " // int_str(size(a%out)) // " lines")
    end subroutine cli_refusals

    !> Orbits of the planar pendulum (the start, or `orbits` perturbed ones) with (8, 7, 9),
    !! h = 1/16 to T = 6 and a section.
    subroutine run_planar(expression, direction, limit, threads, results, error, orbits)
        character(len=*), intent(in) :: expression
        integer, intent(in) :: direction, limit, threads
        type(ensemble_result_t), allocatable, intent(out) :: results(:)
        type(test_error_t), allocatable, intent(inout) :: error
        integer, intent(in), optional :: orbits
        type(planar_pendulum) :: sys
        sys = planar_pendulum()
        call run_system(sys, expression, direction, limit, threads, results, error, orbits)
    end subroutine run_planar

    subroutine run_system(sys, expression, direction, limit, threads, results, error, orbits)
        class(constrained_hamiltonian), intent(in), target :: sys
        character(len=*), intent(in) :: expression
        integer, intent(in) :: direction, limit, threads
        type(ensemble_result_t), allocatable, intent(out) :: results(:)
        type(test_error_t), allocatable, intent(inout) :: error
        integer, intent(in), optional :: orbits
        type(ensemble_states_t) :: states
        type(ensemble_settings_t) :: settings
        type(section_t), target :: section
        type(openmp_farm) :: farm
        type(holosym_status_t) :: status
        integer :: count
        count = 1
        if (present(orbits)) count = orbits
        call planar_states(sys, count, states)
        call make_section(sys, expression, direction, section, status)
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, status%message)
        if (allocated(error)) return
        settings%order_m = 8
        settings%order_n = 7
        settings%gauss_points = 9
        settings%step_size = 1.0_wp / 16
        settings%final_time = 6
        settings%project = .true.
        settings%section => section
        settings%crossing_limit = limit
        farm%threads = threads
        call run_ensemble(sys, states, settings, results, status, farm=farm)
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, status%message)
    end subroutine run_system

    !> The pendulum's start at 1 rad (count = 1) or `count` states perturbed around it.
    subroutine planar_states(sys, count, states)
        class(constrained_hamiltonian), intent(in) :: sys
        integer, intent(in) :: count
        type(ensemble_states_t), intent(out) :: states
        type(holosym_status_t) :: status
        real(wp) :: q(2), p(2)
        if (sys%n /= 2) return
        q = [sin(1.0_wp), -cos(1.0_wp)]
        p = 0
        if (count == 1) then
            states%id = [1]
            states%q = reshape(q, [2, 1])
            states%p = reshape(p, [2, 1])
        else
            call perturbed_states(q, p, count, 1.0e-3_wp, 1, states, status)
        end if
    end subroutine planar_states

end module test_sections
