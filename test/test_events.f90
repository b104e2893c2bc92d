!> Tests of events (`integrate_events`): crossing times of the planar pendulum against the
!! exact times from the complete elliptic integral K (arithmetic-geometric mean, computed
!! here independently of the library), directions, terminal events, several events in
!! one step in time order, a crossing at a step's end reported once, and bad input.
module test_events
    use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan
    use holosym_kinds, only: wp
    use holosym_status_codes, only: holosym_status_t, real_str, int_str, HOLOSYM_SUCCESS, &
        HOLOSYM_INVALID_ARGUMENT, HOLOSYM_NONFINITE_VALUE, HOLOSYM_SIZE_MISMATCH, &
        HOLOSYM_INVALID_MODEL
    use holosym_models, only: planar_pendulum
    use holosym_integrator, only: constrained_integrator
    use holosym_events, only: event_set, event_t, integrate_events, model_events, EVENT_ANY, &
        EVENT_RISING, EVENT_FALLING
    use holosym_formula_model, only: formula_model, model_from_text
    use holosym_testing, only: test_case_t, new_test, test_error_t, check, check_status_code
    implicit none
    private
    public :: events_tests, elliptic_k, pendulum_text

    real(wp), parameter :: eps = epsilon(1.0_wp)
    !> The scheme's accuracy at (8, 7, 9), h = 1/16 over a few periods (about 1e-32 in
    !! real128), with room: event times and states are steps of the scheme.
    real(wp), parameter :: scheme_accuracy = max(1.0e-29_wp, 1.0e4_wp * eps)

    !> g = x (the pendulum passes the vertical), with a direction and terminal flag.
    type, extends(event_set) :: vertical_passage
        integer :: wanted = EVENT_ANY
        logical :: stops = .false.
    contains
        procedure :: count => one_event
        procedure :: value => horizontal_position
        procedure :: direction => wanted_direction
        procedure :: terminal => stops_run
    end type vertical_passage

    !> g_k = t - times(k): crossings at known times; NaN from t > nan_after.
    type, extends(event_set) :: clock_events
        real(wp), allocatable :: times(:)
        real(wp) :: nan_after = huge(1.0_wp)
    contains
        procedure :: count => clock_count
        procedure :: value => clock_value
    end type clock_events

contains

    !> The tests of this suite.
    function events_tests() result(tests)
        type(test_case_t), allocatable :: tests(:)
        tests = [ &
            new_test("crossing_times_match_elliptic_reference", elliptic_reference), &
            new_test("direction_and_terminal", direction_and_terminal), &
            new_test("several_in_one_step_in_time_order", time_order), &
            new_test("bad_input_and_nan", bad_input), &
            new_test("event_statements_of_a_model", model_statements), &
            new_test("event_statements_refused", model_statements_refused) &
        ]
    end function events_tests

    !> The planar pendulum released at rest at 1 rad (g = l = 1) passes the vertical at
    !! t = (2j + 1) K(sin(1/2)). With (8, 7, 9), h = 1/16, 96 steps: two passages, falling
    !! then rising, at those times within the scheme's accuracy; the event states are on
    !! the constraint (|x^2 + y^2 - 1| at round-off) with x = 0 to the same accuracy.
    subroutine elliptic_reference(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(event_t), allocatable :: found(:)
        real(wp) :: quarter
        integer :: j
        call run(vertical_passage(), 96, found, error)
        if (allocated(error)) return
        quarter = elliptic_k(sin(0.5_wp))
        call check(error, size(found) == 2, int_str(size(found)) // " events, expected 2")
        if (allocated(error)) return
        do j = 1, 2
            call check(error, abs(found(j)%t - (2 * j - 1) * quarter) <= scheme_accuracy, &
                "passage " // int_str(j) // " at " // real_str(found(j)%t) // ", exact " // &
                real_str((2 * j - 1) * quarter) // ", difference " // &
                real_str(abs(found(j)%t - (2 * j - 1) * quarter)))
            call check(error, found(j)%direction == merge(-1, 1, j == 1), "direction " // &
                int_str(found(j)%direction) // " of passage " // int_str(j))
            call check(error, abs(found(j)%q(1)) <= scheme_accuracy .and. &
                abs(sum(found(j)%q**2) - 1) <= 64 * eps, "state of passage " // &
                int_str(j) // ": x = " // real_str(found(j)%q(1)) // ", |q|^2 - 1 = " // &
                real_str(sum(found(j)%q**2) - 1))
            call check(error, found(j)%step == ceiling((2 * j - 1) * quarter * 16), &
                "passage " // int_str(j) // " reported in step " // int_str(found(j)%step))
        end do
    end subroutine elliptic_reference

    !> Only rising passages: one, at 3 K. A terminal falling passage: the run ends there
    !! (stopped, q and p the event's state, one event found).
    subroutine direction_and_terminal(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(event_t), allocatable :: found(:)
        type(planar_pendulum) :: sys
        type(constrained_integrator) :: integ
        type(holosym_status_t) :: status
        real(wp) :: q(2), p(2), quarter
        logical :: stopped
        quarter = elliptic_k(sin(0.5_wp))
        call run(vertical_passage(wanted=EVENT_RISING), 96, found, error)
        if (allocated(error)) return
        call check(error, size(found) == 1, int_str(size(found)) // " rising events")
        if (allocated(error)) return
        call check(error, abs(found(1)%t - 3 * quarter) <= scheme_accuracy .and. &
            found(1)%direction == 1, "rising passage at " // real_str(found(1)%t))
        sys = planar_pendulum()
        call sys%initial_state(q, p)
        call integ%init(sys, 8, 7, 9, status)
        call integrate_events(integ, sys, q, p, 1.0_wp / 16, 96, &
                              vertical_passage(wanted=EVENT_FALLING, stops=.true.), found, &
                              stopped, status)
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, status%message)
        if (allocated(error)) return
        call check(error, stopped .and. size(found) == 1, "terminal: stopped " // &
            merge("T", "F", stopped) // ", " // int_str(size(found)) // " events")
        if (allocated(error)) return
        call check(error, all(q == found(1)%q) .and. all(p == found(1)%p) .and. &
            abs(found(1)%t - quarter) <= scheme_accuracy, "the run did not end at the " // &
            "event (t = " // real_str(found(1)%t) // ")")
    end subroutine direction_and_terminal

    !> g_k = t - (0.30, 0.27, 0.5) with h = 1/4: the three crossings come in time order
    !! (0.27, 0.30 in step 2 and 0.5 at its end, reported once, in step 2), at their times
    !! to round-off.
    subroutine time_order(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(event_t), allocatable :: found(:)
        type(clock_events) :: clock
        integer :: j
        clock%times = [0.30_wp, 0.27_wp, 0.5_wp]
        call run(clock, 4, found, error, h=0.25_wp)
        if (allocated(error)) return
        call check(error, size(found) == 3, int_str(size(found)) // " events, expected 3")
        if (allocated(error)) return
        call check(error, all([(found(j)%index, j = 1, 3)] == [2, 1, 3]) .and. &
            all([(found(j)%step, j = 1, 3)] == 2), "order " // int_str(found(1)%index) // &
            int_str(found(2)%index) // int_str(found(3)%index) // ", steps " // &
            int_str(found(1)%step) // int_str(found(2)%step) // int_str(found(3)%step))
        do j = 1, 3
            call check(error, abs(found(j)%t - clock%times(found(j)%index)) <= 16 * eps, &
                "event " // int_str(found(j)%index) // " at " // real_str(found(j)%t))
        end do
    end subroutine time_order

    !> No event function, samples = 0 or direction 2: HOLOSYM_INVALID_ARGUMENT; q of the
    !! wrong size: HOLOSYM_SIZE_MISMATCH (before any event function sees it); the state
    !! unchanged.
    !! An event function that returns NaN from t = 0.6 on: HOLOSYM_NONFINITE_VALUE after
    !! the step where it did, with the event found before it (t = 0.3).
    subroutine bad_input(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(event_t), allocatable :: found(:)
        type(clock_events) :: clock
        type(planar_pendulum) :: sys
        type(constrained_integrator) :: integ
        type(holosym_status_t) :: status
        real(wp) :: q(2), p(2), q0(2), p0(2)
        logical :: stopped
        integer :: done
        sys = planar_pendulum()
        call sys%initial_state(q0, p0)
        q = q0
        p = p0
        call integ%init(sys, 4, 3, 5, status)
        allocate (clock%times(0))
        call integrate_events(integ, sys, q, p, 0.25_wp, 4, clock, found, stopped, status)
        call check_status_code(error, status%code, HOLOSYM_INVALID_ARGUMENT, "no function")
        clock%times = [0.3_wp]
        call integrate_events(integ, sys, q, p, 0.25_wp, 4, clock, found, stopped, status, &
                              samples=0)
        call check_status_code(error, status%code, HOLOSYM_INVALID_ARGUMENT, "samples 0")
        call integrate_events(integ, sys, q, p, 0.25_wp, 4, vertical_passage(wanted=2), found, &
                              stopped, status)
        call check_status_code(error, status%code, HOLOSYM_INVALID_ARGUMENT, "direction 2")
        call integrate_events(integ, sys, q(1:1), p, 0.25_wp, 4, clock, found, stopped, status)
        call check_status_code(error, status%code, HOLOSYM_SIZE_MISMATCH, "size of q")
        call check(error, all(q == q0) .and. all(p == p0), "state changed by a refusal")
        clock%nan_after = 0.6_wp
        call integrate_events(integ, sys, q, p, 0.25_wp, 8, clock, found, stopped, status, &
                              steps_done=done)
        call check_status_code(error, status%code, HOLOSYM_NONFINITE_VALUE, "NaN: " // &
            status%message)
        if (allocated(error)) return
        call check(error, done == 3 .and. size(found) == 1, int_str(done) // " steps, " // &
            int_str(size(found)) // " events before the NaN (expected 3 and 1)")
    end subroutine bad_input

    !> `event` statements of a model file: the planar pendulum's twin with `event
    !! vertical: x` (any direction) and `event low: y + 0.9 rising` reports, in 96 steps of
    !! 1/16 with (8, 7, 9), four events in time order: the passages of the vertical at K
    !! and 3K (within the scheme's accuracy) each followed by y rising through -0.9 (y there
    !! within the scheme's accuracy); with `stop` on `vertical` the run ends at the first
    !! passage, with the state there.
    subroutine model_statements(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(formula_model), target :: model
        type(constrained_integrator) :: integ
        type(holosym_status_t) :: status
        type(event_t), allocatable :: found(:)
        real(wp) :: q(2), p(2), quarter
        logical :: stopped
        integer :: trial, k
        quarter = elliptic_k(sin(0.5_wp))
        do trial = 1, 2
            call model_from_text(pendulum_text() // new_line("a") // "event vertical: x" // &
                merge(" stop", "     ", trial == 2) // new_line("a") // &
                "event low: y + 0.9 rising", model, status)
            call check_status_code(error, status%code, HOLOSYM_SUCCESS, status%message)
            if (allocated(error)) return
            call check(error, model%event_count() == 2 .and. model%event_name(1) == &
                "vertical" .and. model%event_direction(2) == EVENT_RISING .and. &
                (model%event_stops(1) .eqv. trial == 2), "the statements as read")
            call model%initial_state(q, p, status)
            call integ%init(model, 8, 7, 9, status)
            call integrate_events(integ, model, q, p, 1.0_wp / 16, 96, &
                                  model_events(model), found, stopped, status)
            call check_status_code(error, status%code, HOLOSYM_SUCCESS, status%message)
            if (allocated(error)) return
            call check(error, size(found) == merge(1, 4, trial == 2) .and. &
                (stopped .eqv. trial == 2), int_str(size(found)) // " events, stopped " // &
                merge("T", "F", stopped))
            if (allocated(error)) return
            call check(error, found(1)%index == 1 .and. abs(found(1)%t - quarter) <= &
                scheme_accuracy, "first passage at " // real_str(found(1)%t))
            if (trial == 2) exit
            call check(error, all([(found(k)%index, k = 1, 4)] == [1, 2, 1, 2]) .and. &
                abs(found(3)%t - 3 * quarter) <= scheme_accuracy .and. &
                all([(found(k)%direction, k = 2, 4, 2)] == 1) .and. &
                all([(abs(found(k)%q(2) + 0.9_wp), k = 2, 4, 2)] <= scheme_accuracy), &
                "the events in order: " // int_str(found(2)%index) // " at " // &
                real_str(found(2)%t) // ", y = " // real_str(found(2)%q(2)))
        end do
        call check(error, all(q == found(1)%q), "the run did not end at the event")
    end subroutine model_statements

    !> Bad `event` statements: each refused with HOLOSYM_INVALID_MODEL and its position.
    subroutine model_statements_refused(error)
        type(test_error_t), allocatable, intent(out) :: error
        character(len=*), parameter :: bad(*) = [character(len=40) :: &
            "event : x", "event e x", "event e:", "event e: x sideways", &
            "event e: 1 + 2", "event e: x rising stop 3"]
        character(len=*), parameter :: said(*) = [character(len=40) :: &
            "expected the event's name", "expected ':'", "expected the expression", &
            "expected rising, falling, any or stop", "depends on no coordinate", &
            "expected an operator, rising"]
        type(formula_model) :: model
        type(holosym_status_t) :: status
        integer :: k
        do k = 1, size(bad)
            call model_from_text(pendulum_text() // new_line("a") // trim(bad(k)), model, &
                                 status, name="m")
            call check_status_code(error, status%code, HOLOSYM_INVALID_MODEL, trim(bad(k)))
            if (allocated(error)) return
            call check(error, index(status%message, "m:7:") == 1 .and. &
                index(status%message, trim(said(k))) > 0, trim(bad(k)) // ": " // &
                status%message)
        end do
        call model_from_text(pendulum_text() // new_line("a") // "event e: x" // &
            new_line("a") // "event e: y", model, status, name="m")
        call check(error, index(status%message, "a second event 'e'") > 0, status%message)
    end subroutine model_statements_refused

    !> The planar pendulum's model text (example/models/planar_pendulum.hsm), six lines.
    function pendulum_text() result(text)
        character(len=:), allocatable :: text
        character(len=1), parameter :: nl = new_line("a")
        text = "# the planar pendulum" // nl // "coordinates x y" // nl // &
            "momenta px py" // nl // "hamiltonian (px^2 + py^2)/2 + y" // nl // &
            "constraint x^2 + y^2 - 1" // nl // "initial x = sin(1), y = -cos(1)"
    end function pendulum_text

    !> The planar pendulum from its initial state with (8, 7, 9) and step h (1/16).
    subroutine run(events, steps, found, error, h)
        class(event_set), intent(in) :: events
        integer, intent(in) :: steps
        type(event_t), allocatable, intent(out) :: found(:)
        type(test_error_t), allocatable, intent(inout) :: error
        real(wp), intent(in), optional :: h
        type(planar_pendulum) :: sys
        type(constrained_integrator) :: integ
        type(holosym_status_t) :: status
        real(wp) :: q(2), p(2), step
        logical :: stopped
        step = 1.0_wp / 16
        if (present(h)) step = h
        sys = planar_pendulum()
        call sys%initial_state(q, p)
        call integ%init(sys, 8, 7, 9, status)
        call integrate_events(integ, sys, q, p, step, steps, events, found, stopped, status)
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, status%message)
    end subroutine run

    !> K(k) = pi / (2 AGM(1, sqrt(1 - k^2))), the arithmetic-geometric mean iterated to
    !! the working precision (quadratic convergence).
    real(wp) function elliptic_k(k) result(quarter)
        real(wp), intent(in) :: k
        real(wp) :: a, b, next
        integer :: i
        a = 1
        b = sqrt(1 - k**2)
        do i = 1, 40
            next = (a + b) / 2
            b = sqrt(a * b)
            a = next
            if (abs(a - b) <= eps * a) exit
        end do
        quarter = 2 * atan(1.0_wp) / a
    end function elliptic_k

    integer function one_event(self)
        class(vertical_passage), intent(in) :: self
        one_event = 1
        if (self%stops) continue
    end function one_event

    real(wp) function horizontal_position(self, k, t, q, p) result(g)
        class(vertical_passage), intent(in) :: self
        integer, intent(in) :: k
        real(wp), intent(in) :: t, q(:), p(:)
        g = q(1)
        if (k < 0 .or. t < 0 .or. size(p) < 0 .or. self%stops) continue
    end function horizontal_position

    integer function wanted_direction(self, k)
        class(vertical_passage), intent(in) :: self
        integer, intent(in) :: k
        wanted_direction = self%wanted
        if (k < 0) continue
    end function wanted_direction

    logical function stops_run(self, k)
        class(vertical_passage), intent(in) :: self
        integer, intent(in) :: k
        stops_run = self%stops
        if (k < 0) continue
    end function stops_run

    integer function clock_count(self)
        class(clock_events), intent(in) :: self
        clock_count = size(self%times)
    end function clock_count

    real(wp) function clock_value(self, k, t, q, p) result(g)
        class(clock_events), intent(in) :: self
        integer, intent(in) :: k
        real(wp), intent(in) :: t, q(:), p(:)
        g = t - self%times(k)
        if (t > self%nan_after) g = ieee_value(g, ieee_quiet_nan)
        if (size(q) < 0 .or. size(p) < 0) continue
    end function clock_value

end module test_events
