!> Tests of the C interface (holosym_c, include/holosym.h), called from Fortran through its
!! bind(C) procedures with bind(C) callbacks, as a C program calls it: the planar pendulum
!! integrated through the handle agrees with the Fortran integrator; dense output inside a
!! C-style observer; every kind of bad input gives its code and message and leaves the
!! arrays unchanged. (`make c-example` builds and runs the C program itself with gcc.)
module test_capi
    use, intrinsic :: iso_c_binding, only: c_int, c_ptr, c_funptr, c_funloc, c_null_ptr, &
        c_null_funptr, c_associated, c_loc, c_char, c_f_pointer
    use holosym_kinds, only: wp, wp_is_double
    use holosym_accuracy, only: accuracy_plan_t, init_for_accuracy
    use holosym_status_codes, only: real_str, int_str, HOLOSYM_SUCCESS, HOLOSYM_INVALID_ARGUMENT, &
        HOLOSYM_INVALID_DIMENSION, HOLOSYM_INVALID_ORDER, HOLOSYM_INVALID_STEP_SIZE, &
        HOLOSYM_NOT_INITIALIZED, HOLOSYM_OUTSIDE_DOMAIN, HOLOSYM_USER_ABORT, &
        HOLOSYM_INVALID_MODEL, HOLOSYM_NONFINITE_VALUE, HOLOSYM_OFF_MANIFOLD, holosym_status_t, &
        status_code_table
    use holosym_integrator, only: constrained_integrator
    use holosym_models, only: planar_pendulum
    use holosym_c, only: holosym_system_c, c_real, holosym_create, holosym_destroy, &
        holosym_status, holosym_message, holosym_step, holosym_integrate, &
        holosym_dense_output, holosym_project, holosym_sizes, holosym_model_create, &
        holosym_model_set_parameter, holosym_model_get_parameter, &
        holosym_model_initial_state, holosym_model_parameter_count, holosym_model_name, &
        holosym_step_p, holosym_integrate_p, holosym_dense_output_p, &
        holosym_model_set_parameter_p, holosym_energy, holosym_constraint, &
        holosym_plan_accuracy, name_parameter_c, name_coordinate_c, name_momentum_c, &
        holosym_integrate_events, holosym_lyapunov_spectrum, holosym_step_tangent, &
        holosym_tangent_basis, holosym_project_tangent
    use holosym_tangent_space, only: tangent_basis, tangent_residual, tangent_tolerance
    use holosym_events, only: event_set, event_t, integrate_events
    use holosym_lyapunov, only: lyapunov_spectrum, lyapunov_result_t
    use holosym_formula_model, only: formula_model, load_model
    use holosym_testing, only: test_case_t, new_test, test_error_t, check, check_status_code
    implicit none
    private
    public :: capi_tests

    real(wp), parameter :: eps = epsilon(1.0_wp)

    !> g = x, the Fortran twin of `c_event_x`.
    type, extends(event_set) :: x_event
    contains
        procedure :: count => x_event_count
        procedure :: value => x_event_value
    end type x_event

contains

    !> The tests of this suite.
    function capi_tests() result(tests)
        type(test_case_t), allocatable :: tests(:)
        tests = [ &
            new_test("pendulum_through_the_c_interface", pendulum_through_c), &
            new_test("observer_and_dense_output", observer_and_dense), &
            new_test("rejects_bad_input", bad_input), &
            new_test("model_through_the_c_interface", model_through_c), &
            new_test("water_through_the_c_interface", water_through_c), &
            new_test("model_calls_reject_bad_input", model_bad_input), &
            new_test("null_arrays_refused", null_arrays), &
            new_test("destroyed_and_foreign_handles_refused", dead_handles), &
            new_test("header_and_docs_follow_the_status_table", header_codes), &
            new_test("reals_through_pointers_match_values", pointer_calls), &
            new_test("plan_accuracy_as_in_fortran", plan_accuracy), &
            new_test("events_as_in_fortran", events_through_c), &
            new_test("lyapunov_as_in_fortran", lyapunov_through_c), &
            new_test("tangent_map_as_in_fortran", tangent_through_c)]
    end function capi_tests

    ! ---------------------------------------------------------------- C callbacks

    integer(c_int) function c_h(n, q, p, energy, data) bind(C)
        integer(c_int), value :: n
        real(c_real), intent(in) :: q(*), p(*)
        real(c_real), intent(out) :: energy
        type(c_ptr), value :: data
        energy = (p(1)**2 + p(2)**2) / 2 + q(2)
        c_h = 0
    end function c_h

    integer(c_int) function c_hq(n, q, p, gradient, data) bind(C)
        integer(c_int), value :: n
        real(c_real), intent(in) :: q(*), p(*)
        real(c_real), intent(out) :: gradient(*)
        type(c_ptr), value :: data
        gradient(1:2) = [0.0_c_real, 1.0_c_real]
        c_hq = 0
    end function c_hq

    !> dH/dq that fails (returns 7) whenever data is not NULL.
    integer(c_int) function c_hq_failing(n, q, p, gradient, data) bind(C)
        integer(c_int), value :: n
        real(c_real), intent(in) :: q(*), p(*)
        real(c_real), intent(out) :: gradient(*)
        type(c_ptr), value :: data
        gradient(1:2) = [0.0_c_real, 1.0_c_real]
        c_hq_failing = 0
        if (c_associated(data)) c_hq_failing = 7
    end function c_hq_failing

    integer(c_int) function c_hp(n, q, p, gradient, data) bind(C)
        integer(c_int), value :: n
        real(c_real), intent(in) :: q(*), p(*)
        real(c_real), intent(out) :: gradient(*)
        type(c_ptr), value :: data
        gradient(1:2) = p(1:2)
        c_hp = 0
    end function c_hp

    integer(c_int) function c_phi(n, m, q, values, data) bind(C)
        integer(c_int), value :: n, m
        real(c_real), intent(in) :: q(*)
        real(c_real), intent(out) :: values(*)
        type(c_ptr), value :: data
        values(1) = q(1)**2 + q(2)**2 - 1
        c_phi = 0
    end function c_phi

    integer(c_int) function c_jac(n, m, q, values, data) bind(C)
        integer(c_int), value :: n, m
        real(c_real), intent(in) :: q(*)
        real(c_real), intent(out) :: values(*)
        type(c_ptr), value :: data
        values(1:2) = 2 * q(1:2)
        c_jac = 0
    end function c_jac

    !> Observer: x~ in the middle of step 3 into data (a real(c_real) array of 2), stop at
    !! step 5.
    integer(c_int) function c_watch(handle, step, t, q, p, data) bind(C)
        type(c_ptr), value :: handle
        integer(c_int), value :: step
        real(c_real), value :: t
        real(c_real), intent(in) :: q(*), p(*)
        type(c_ptr), value :: data
        real(c_real), pointer :: seen(:)
        real(c_real), target :: qd(2), pd(2), lambda(1)
        integer(c_int) :: code
        c_watch = 0
        call c_f_pointer(data, seen, [2])
        if (step == 3) then
            code = holosym_dense_output(handle, 0.5_c_real, c_loc(qd), c_loc(pd), c_loc(lambda))
            seen(1) = qd(1)
            seen(2) = real(code, c_real)
        end if
        if (step == 5) c_watch = 1
    end function c_watch

    !> Observer of holosym_integrate_p: t of each step into data (a real(c_real) array of
    !! 8), stop at step 3.
    integer(c_int) function c_watch_p(handle, step, t, q, p, data) bind(C)
        type(c_ptr), value :: handle
        integer(c_int), value :: step
        real(c_real), intent(in) :: t
        real(c_real), intent(in) :: q(*), p(*)
        type(c_ptr), value :: data
        real(c_real), pointer :: seen(:)
        call c_f_pointer(data, seen, [8])
        seen(step) = t
        c_watch_p = 0
        if (step == 3) c_watch_p = 1
    end function c_watch_p

    !> Event function of holosym_integrate_events: g = x; it fails (returns 7) from t = 0.5
    !! on when data (a real(c_real) array of 16) holds -1 in its last entry.
    integer(c_int) function c_event_x(k, t, q, p, value, data) bind(C)
        integer(c_int), value :: k
        real(c_real), intent(in) :: t
        real(c_real), intent(in) :: q(*), p(*)
        real(c_real), intent(out) :: value
        type(c_ptr), value :: data
        real(c_real), pointer :: seen(:)
        value = q(1)
        c_event_x = 0
        if (c_associated(data)) then
            call c_f_pointer(data, seen, [16])
            if (seen(16) == -1 .and. t >= 0.5_c_real) c_event_x = 7
        end if
        if (k < 0 .or. p(1) /= p(1)) continue
    end function c_event_x

    !> Receives events into data (a real(c_real) array of 16): the count in the first
    !! entry, then index, direction, t and x of each.
    integer(c_int) function c_event_seen(k, direction, t, q, p, lambda, data) bind(C)
        integer(c_int), value :: k, direction
        real(c_real), intent(in) :: t
        real(c_real), intent(in) :: q(*), p(*), lambda(*)
        type(c_ptr), value :: data
        real(c_real), pointer :: seen(:)
        integer :: j
        call c_f_pointer(data, seen, [16])
        seen(1) = seen(1) + 1
        j = 2 + 4 * (nint(seen(1)) - 1)
        if (j + 3 <= 16) seen(j:j + 3) = [real(k, c_real), real(direction, c_real), t, q(1)]
        c_event_seen = 0
        if (p(1) /= p(1) .or. lambda(1) /= lambda(1)) continue
    end function c_event_seen

    !> The planar pendulum's system struct.
    function pendulum_struct() result(system)
        type(holosym_system_c) :: system
        system%n = 2
        system%m = 1
        system%hamiltonian = c_funloc(c_h)
        system%dh_dq = c_funloc(c_hq)
        system%dh_dp = c_funloc(c_hp)
        system%constraint = c_funloc(c_phi)
        system%constraint_jacobian = c_funloc(c_jac)
        system%data = c_null_ptr
    end function pendulum_struct

    !> The message of the handle's last call.
    function message_of(handle) result(text)
        type(c_ptr), intent(in) :: handle
        character(len=:), allocatable :: text
        character(kind=c_char), target :: buffer(400)
        integer :: length, i
        length = holosym_message(handle, c_loc(buffer), 400_c_int)
        allocate (character(len=min(length, 399)) :: text)
        do i = 1, len(text)
            text(i:i) = buffer(i)
        end do
    end function message_of

    ! ---------------------------------------------------------------- tests

    !> 40 steps through the handle, and through the Fortran integrator (general scheme, as
    !! for callbacks): the same states to round-off.
    subroutine pendulum_through_c(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(holosym_system_c), target :: system
        type(planar_pendulum) :: sys
        type(constrained_integrator) :: integrator
        type(c_ptr) :: handle
        real(c_real), target :: q(2), p(2)
        real(wp) :: qf(2), pf(2)
        integer(c_int), target :: done
        system = pendulum_struct()
        handle = holosym_create(c_loc(system), 3_c_int, 2_c_int, 4_c_int)
        call check(error, c_associated(handle), "a handle")
        call check_status_code(error, int(holosym_status(handle)), HOLOSYM_SUCCESS, "create")
        if (allocated(error)) return
        sys = planar_pendulum()
        call sys%initial_state(qf, pf)
        q = qf
        p = pf
        call check_status_code(error, int(holosym_step(handle, c_loc(q), c_loc(p), 0.0625_c_real)), &
            HOLOSYM_SUCCESS, "step")
        call check_status_code(error, int(holosym_integrate(handle, c_loc(q), c_loc(p), 0.0625_c_real, &
            39_c_int, c_null_funptr, c_null_ptr, c_loc(done))), HOLOSYM_SUCCESS, "integrate")
        call check(error, done == 39, "steps_done is not 39")
        integrator%structured = .false.
        call integrator%init(sys, 3, 2, 4)
        call integrator%integrate(sys, qf, pf, 0.0625_wp, 40)
        call check(error, maxval(abs(q - qf)) <= 1.0e3_wp * eps .and. &
            maxval(abs(p - pf)) <= 1.0e3_wp * eps, "C and Fortran states differ")
        call holosym_destroy(handle)
    end subroutine pendulum_through_c

    !> A C observer sees the dense output of the step just taken and stops the run.
    subroutine observer_and_dense(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(holosym_system_c), target :: system
        type(planar_pendulum) :: sys
        type(constrained_integrator) :: integrator
        type(c_ptr) :: handle
        real(c_real), target :: seen(2)
        real(c_real), target :: q(2), p(2)
        real(wp) :: qf(2), pf(2), qd(2), pd(2), lambda(1)
        integer(c_int), target :: done
        integer(c_int) :: code
        system = pendulum_struct()
        handle = holosym_create(c_loc(system), 3_c_int, 2_c_int, 4_c_int)
        sys = planar_pendulum()
        call sys%initial_state(qf, pf)
        q = qf
        p = pf
        seen = -1
        code = holosym_integrate(handle, c_loc(q), c_loc(p), 0.0625_c_real, 10_c_int, c_funloc(c_watch), &
                                 c_loc(seen), c_loc(done))
        call check_status_code(error, int(code), HOLOSYM_USER_ABORT, "observer stops at 5")
        call check(error, done == 5 .and. nint(seen(2)) == HOLOSYM_SUCCESS, &
            "dense output inside the observer")
        integrator%structured = .false.
        call integrator%init(sys, 3, 2, 4)
        call integrator%integrate(sys, qf, pf, 0.0625_wp, 3)
        call integrator%dense_output(0.5_wp, qd, pd, lambda)
        call check(error, abs(seen(1) - qd(1)) <= 1.0e3_wp * eps, "x~ of step 3 differs " // &
            "from the Fortran integrator's dense output")
        call holosym_destroy(handle)
    end subroutine observer_and_dense

    !> Each bad input: its code, a message, the arrays unchanged.
    subroutine bad_input(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(holosym_system_c), target :: system
        type(c_ptr) :: handle
        real(c_real), target :: q(2), p(2), q0(2), p0(2), lambda(1)
        real(c_real), target :: marker
        character(len=:), allocatable :: message
        character(kind=c_char), target :: tiny_buffer(4)
        integer(c_int) :: code
        q0 = [sin(1.0_c_real), -cos(1.0_c_real)]
        p0 = 0
        q = q0
        p = p0
        call check(error, .not. c_associated(holosym_create(c_null_ptr, 3_c_int, 2_c_int, &
            4_c_int)), "NULL system: NULL handle")
        call check_status_code(error, int(holosym_status(c_null_ptr)), &
            HOLOSYM_NOT_INITIALIZED, "status of NULL")
        call check_status_code(error, int(holosym_step(c_null_ptr, c_loc(q), c_loc(p), 0.0625_c_real)), &
            HOLOSYM_NOT_INITIALIZED, "step on NULL")
        system = pendulum_struct()
        system%dh_dp = c_null_funptr
        handle = holosym_create(c_loc(system), 3_c_int, 2_c_int, 4_c_int)
        call check_status_code(error, int(holosym_status(handle)), HOLOSYM_INVALID_ARGUMENT, &
            "NULL callback")
        call check(error, index(message_of(handle), "callback") > 0, "message: " // &
            message_of(handle))
        call check_status_code(error, int(holosym_step(handle, c_loc(q), c_loc(p), 0.0625_c_real)), &
            HOLOSYM_NOT_INITIALIZED, "step on a failed handle")
        call holosym_destroy(handle)
        system = pendulum_struct()
        system%m = 2
        handle = holosym_create(c_loc(system), 3_c_int, 2_c_int, 4_c_int)
        call check_status_code(error, int(holosym_status(handle)), HOLOSYM_INVALID_DIMENSION, &
            "m = n")
        call check(error, index(message_of(handle), "m = 2") > 0, "message names m")
        call holosym_destroy(handle)
        system = pendulum_struct()
        handle = holosym_create(c_loc(system), 0_c_int, 2_c_int, 4_c_int)
        call check_status_code(error, int(holosym_status(handle)), HOLOSYM_INVALID_ORDER, "M = 0")
        call holosym_destroy(handle)
        handle = holosym_create(c_loc(system), 3_c_int, 2_c_int, 4_c_int)
        code = holosym_dense_output(handle, 0.5_c_real, c_loc(q), c_loc(p), c_loc(lambda))
        call check_status_code(error, int(code), HOLOSYM_NOT_INITIALIZED, "dense before a step")
        code = holosym_step(handle, c_loc(q), c_loc(p), -1.0_c_real)
        call check_status_code(error, int(code), HOLOSYM_INVALID_STEP_SIZE, "h = -1")
        call check(error, all(q == q0) .and. all(p == p0), "state unchanged")
        code = holosym_message(handle, c_loc(tiny_buffer), 4_c_int)
        call check(error, code == len(message_of(handle)) .and. code > 3 .and. &
            tiny_buffer(4) == char(0), "truncated message NUL-terminated, full length returned")
        q = [0.6_c_real, 0.8_c_real]
        code = holosym_project(handle, c_loc(q), c_loc(p))
        call check(error, code == HOLOSYM_SUCCESS .and. abs(q(1)**2 + q(2)**2 - 1) <= 8 * eps, &
            "project")
        call holosym_destroy(handle)
        ! A callback that fails: named in the message, the state kept.
        system = pendulum_struct()
        system%dh_dq = c_funloc(c_hq_failing)
        system%data = c_loc(marker)
        handle = holosym_create(c_loc(system), 3_c_int, 2_c_int, 4_c_int)
        q = q0
        p = p0
        code = holosym_step(handle, c_loc(q), c_loc(p), 0.0625_c_real)
        message = message_of(handle)
        call check_status_code(error, int(code), HOLOSYM_OUTSIDE_DOMAIN, "failing callback")
        call check(error, index(message, "dh_dq returned 7") > 0, "message: " // message)
        call check(error, all(q == q0) .and. all(p == p0), "state unchanged")
        call holosym_destroy(handle)
        call holosym_destroy(c_null_ptr)
    end subroutine bad_input

    ! ---------------------------------------------------------------- models

    !> A Fortran string as a NUL-terminated C string.
    function c_text(text) result(chars)
        character(len=*), intent(in) :: text
        character(kind=c_char), allocatable :: chars(:)
        integer :: i
        allocate (chars(len(text) + 1))
        do i = 1, len(text)
            chars(i) = text(i:i)
        end do
        chars(len(text) + 1) = achar(0)
    end function c_text

    !> The whole text of a file, lines joined by line feeds.
    function file_text(path) result(text)
        character(len=*), intent(in) :: path
        character(len=:), allocatable :: text
        character(len=4096) :: line
        integer :: unit, ios
        text = ""
        open (newunit=unit, file=path, status="old", action="read")
        do
            read (unit, '(a)', iostat=ios) line
            if (ios /= 0) exit
            text = text // trim(line) // achar(10)
        end do
        close (unit)
    end function file_text

    !> The four-bar model through holosym_model_create: sizes, names, the initial state
    !! and 40 steps agree with the Fortran model and integrator to the bit; a parameter set
    !! through the handle changes the start.
    subroutine model_through_c(error)
        type(test_error_t), allocatable, intent(out) :: error
        character(kind=c_char), allocatable, target :: text(:), name(:)
        type(c_ptr) :: handle
        type(formula_model) :: model
        type(constrained_integrator) :: integ
        type(holosym_status_t) :: status
        integer(c_int), target :: n, m, done
        real(c_real), target :: q(4), p(4), value
        real(wp) :: qf(4), pf(4)
        character(kind=c_char), target :: buffer(16)
        text = c_text(file_text("example/models/fourbar.hsm"))
        handle = holosym_model_create(c_loc(text), 4_c_int, 3_c_int, 5_c_int)
        call check_status_code(error, int(holosym_status(handle)), HOLOSYM_SUCCESS, &
            message_of(handle))
        if (allocated(error)) return
        call check_status_code(error, int(holosym_sizes(handle, c_loc(n), c_loc(m))), &
            HOLOSYM_SUCCESS, "sizes")
        call check(error, n == 4 .and. m == 3, "n = 4, m = 3")
        call check(error, holosym_model_parameter_count(handle) == 9, "9 parameters")
        n = holosym_model_name(handle, name_momentum_c, 2_c_int, c_loc(buffer), 16_c_int)
        call check(error, n == 3 .and. all(buffer(1:4) == ["p", "y", "b", achar(0)]), &
            "momentum 2 is pyb")
        if (allocated(error)) return
        call check_status_code(error, int(holosym_model_initial_state(handle, c_loc(q), c_loc(p))), &
            HOLOSYM_SUCCESS, message_of(handle))
        call check(error, index(message_of(handle), "not tangent") > 0, "the start's note")
        call check_status_code(error, int(holosym_integrate(handle, c_loc(q), c_loc(p), 1.0_c_real / 32, &
            40_c_int, c_null_funptr, c_null_ptr, c_loc(done))), HOLOSYM_SUCCESS, &
            message_of(handle))
        if (allocated(error)) return
        call load_model("example/models/fourbar.hsm", model, status)
        call model%initial_state(qf, pf, status)
        call integ%init(model, 4, 3, 5, status)
        call integ%integrate(model, qf, pf, 1.0_wp / 32, 40, status=status)
        call check(error, all(real(q, wp) == qf) .and. all(real(p, wp) == pf), &
            "the C handle and the Fortran integrator differ")
        if (allocated(error)) return
        name = c_text("omega")
        call check_status_code(error, int(holosym_model_set_parameter(handle, c_loc(name), &
            3.0_c_real)), HOLOSYM_SUCCESS, message_of(handle))
        call check_status_code(error, int(holosym_model_get_parameter(handle, c_loc(name), &
            c_loc(value))), HOLOSYM_SUCCESS, message_of(handle))
        call check(error, value == 3, "omega reads back 3")
        call check_status_code(error, int(holosym_model_initial_state(handle, c_loc(q), c_loc(p))), &
            HOLOSYM_SUCCESS, message_of(handle))
        call model%set_parameter("omega", 3.0_wp)
        call model%initial_state(qf, pf, status)
        call check(error, all(real(p, wp) == pf), "the start follows omega")
        call holosym_destroy(handle)
    end subroutine model_through_c

    !> The water molecule through holosym_model_create gives, at T = 10 with (8, 7, 9) and
    !! h = 1/16, the bits of the Fortran model (which agrees with its 50-digit reference
    !! there: formula/water_and_fourbar_match_40_digit_references).
    subroutine water_through_c(error)
        type(test_error_t), allocatable, intent(out) :: error
        character(kind=c_char), allocatable, target :: text(:)
        type(c_ptr) :: handle
        type(formula_model) :: model
        type(constrained_integrator) :: integ
        type(holosym_status_t) :: status
        integer(c_int), target :: done
        real(c_real), target :: q(9), p(9)
        real(wp) :: qf(9), pf(9), difference
        character(len=16) :: shown
        text = c_text(file_text("example/models/water.hsm"))
        handle = holosym_model_create(c_loc(text), 8_c_int, 7_c_int, 9_c_int)
        call check_status_code(error, int(holosym_status(handle)), HOLOSYM_SUCCESS, &
            message_of(handle))
        if (allocated(error)) return
        call check_status_code(error, int(holosym_model_initial_state(handle, c_loc(q), c_loc(p))), &
            HOLOSYM_SUCCESS, message_of(handle))
        call check_status_code(error, int(holosym_integrate(handle, c_loc(q), c_loc(p), 1.0_c_real / 16, &
            160_c_int, c_null_funptr, c_null_ptr, c_loc(done))), HOLOSYM_SUCCESS, &
            message_of(handle))
        call holosym_destroy(handle)
        if (allocated(error)) return
        call load_model("example/models/water.hsm", model, status)
        call model%initial_state(qf, pf, status)
        call integ%init(model, 8, 7, 9, status)
        call integ%integrate(model, qf, pf, 1.0_wp / 16, 160, status=status)
        difference = max(maxval(abs(real(q, wp) - qf)), maxval(abs(real(p, wp) - pf)))
        write (shown, '(es12.4)') difference
        ! status%ok() here, where the C function holosym_status is visible: a module of that
        ! name made gfortran call the C function for the type-bound `ok`.
        call check(error, status%ok(), "Fortran path: " // status%message)
        write (shown, '(es12.4)') difference
        call check(error, difference == 0, "the C handle and the " // &
            "Fortran integrator differ by " // trim(shown))
    end subroutine water_through_c

    !> Bad model text, names, indices and handles: each call fails with its code and a
    !! message, and leaves the arrays unchanged.
    subroutine model_bad_input(error)
        type(test_error_t), allocatable, intent(out) :: error
        character(kind=c_char), allocatable, target :: text(:), name(:)
        type(c_ptr) :: handle, callbacks
        type(holosym_system_c), target :: system
        real(c_real), target :: q(2), p(2)
        real(c_real), target :: value
        character(kind=c_char), target :: buffer(16)
        text = c_text("coordinates x y" // achar(10) // "momenta px py" // achar(10) // &
            "hamiltonian px^2 + z")
        handle = holosym_model_create(c_loc(text), 2_c_int, 1_c_int, 3_c_int)
        call check_status_code(error, int(holosym_status(handle)), HOLOSYM_INVALID_MODEL, &
            "bad model")
        call check(error, index(message_of(handle), "model:3:20: unknown name 'z'") == 1, &
            message_of(handle))
        q = 7
        p = 8
        call check_status_code(error, int(holosym_model_initial_state(handle, c_loc(q), c_loc(p))), &
            HOLOSYM_NOT_INITIALIZED, "initial state of a refused model")
        call check_status_code(error, int(holosym_step(handle, c_loc(q), c_loc(p), 0.1_c_real)), &
            HOLOSYM_NOT_INITIALIZED, "step of a refused model")
        call check(error, all(q == 7) .and. all(p == 8), "arrays unchanged")
        call holosym_destroy(handle)
        if (allocated(error)) return
        call check(error, .not. c_associated(holosym_model_create(c_null_ptr, 2_c_int, &
            1_c_int, 3_c_int)), "NULL text gives NULL")
        text = c_text("coordinates x y" // achar(10) // "momenta px py" // achar(10) // &
            "parameters g = 1" // achar(10) // "hamiltonian (px^2 + py^2)/2 + g*y" // &
            achar(10) // "constraint x^2 + y^2 - 1")
        handle = holosym_model_create(c_loc(text), 2_c_int, 1_c_int, 3_c_int)
        call check_status_code(error, int(holosym_status(handle)), HOLOSYM_SUCCESS, &
            message_of(handle))
        name = c_text("gg")
        call check_status_code(error, int(holosym_model_set_parameter(handle, c_loc(name), &
            2.0_c_real)), HOLOSYM_INVALID_ARGUMENT, "unknown parameter")
        call check(error, index(message_of(handle), "no parameter 'gg' (its parameters: g)") &
            > 0, message_of(handle))
        call check_status_code(error, int(holosym_model_get_parameter(handle, c_null_ptr, &
            c_loc(value))), HOLOSYM_INVALID_ARGUMENT, "NULL name")
        call check_status_code(error, int(holosym_model_initial_state(handle, c_loc(q), c_loc(p))), &
            HOLOSYM_INVALID_ARGUMENT, "no initial state")
        call check(error, index(message_of(handle), "states no initial state") > 0, &
            message_of(handle))
        call check(error, holosym_model_name(handle, 7_c_int, 1_c_int, c_loc(buffer), 16_c_int) == &
            HOLOSYM_INVALID_ARGUMENT .and. holosym_model_name(handle, name_coordinate_c, &
            3_c_int, c_loc(buffer), 16_c_int) == HOLOSYM_INVALID_ARGUMENT, "name out of range")
        call holosym_destroy(handle)
        if (allocated(error)) return
        system = pendulum_struct()
        callbacks = holosym_create(c_loc(system), 2_c_int, 1_c_int, 3_c_int)
        call check_status_code(error, int(holosym_model_initial_state(callbacks, c_loc(q), c_loc(p))), &
            HOLOSYM_INVALID_ARGUMENT, "a handle of callbacks is not a model")
        call check(error, index(message_of(callbacks), "made by holosym_create") > 0, &
            message_of(callbacks))
        call holosym_destroy(callbacks)
    end subroutine model_bad_input

    ! ---------------------------------------------------------------- contract

    !> Every array argument checked: a NULL q, p or lambda (m > 0) fails the call with
    !! HOLOSYM_INVALID_ARGUMENT naming the function and the argument, the other arrays
    !! unchanged; a NULL message buffer gets nothing and the full length is returned.
    subroutine null_arrays(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(holosym_system_c), target :: system
        type(c_ptr) :: handle, model
        real(c_real), target :: q(2), p(2), q0(2), p0(2), lambda(1)
        character(kind=c_char), allocatable, target :: text(:)
        integer(c_int) :: code
        q0 = [sin(1.0_c_real), -cos(1.0_c_real)]
        p0 = 0
        system = pendulum_struct()
        handle = holosym_create(c_loc(system), 3_c_int, 2_c_int, 4_c_int)
        q = q0
        p = p0
        call expect(holosym_step(handle, c_null_ptr, c_loc(p), 0.0625_c_real), &
                    "holosym_step: q is NULL")
        call expect(holosym_step(handle, c_loc(q), c_null_ptr, 0.0625_c_real), &
                    "holosym_step: p is NULL")
        call expect(holosym_integrate(handle, c_null_ptr, c_loc(p), 0.0625_c_real, 3_c_int, &
            c_null_funptr, c_null_ptr, c_null_ptr), "holosym_integrate: q is NULL")
        call expect(holosym_project(handle, c_loc(q), c_null_ptr), "holosym_project: p is NULL")
        if (allocated(error)) return
        call check(error, all(q == q0) .and. all(p == p0), "arrays unchanged")
        if (allocated(error)) return
        code = holosym_step(handle, c_loc(q), c_loc(p), 0.0625_c_real)
        call check_status_code(error, int(code), HOLOSYM_SUCCESS, "a step")
        if (allocated(error)) return
        call expect(holosym_dense_output(handle, 0.5_c_real, c_loc(q0), c_loc(p0), &
                                         c_null_ptr), "holosym_dense_output: lambda is NULL")
        call expect(holosym_dense_output(handle, 0.5_c_real, c_null_ptr, c_loc(p0), &
                                         c_loc(lambda)), "holosym_dense_output: q is NULL")
        if (allocated(error)) return
        call check(error, holosym_message(handle, c_null_ptr, 100_c_int) == &
            len(message_of(handle)), "a NULL buffer: the length, nothing copied")
        call holosym_destroy(handle)
        text = c_text(file_text("example/models/fourbar.hsm"))
        model = holosym_model_create(c_loc(text), 2_c_int, 1_c_int, 3_c_int)
        handle = model
        call expect(holosym_model_initial_state(model, c_loc(q), c_null_ptr), &
                    "holosym_model_initial_state: p is NULL")
        call check(error, holosym_model_name(model, name_coordinate_c, 1_c_int, c_null_ptr, &
            8_c_int) > 0, "model name into a NULL buffer: the length")
        call holosym_destroy(model)
    contains
        subroutine expect(code, text)
            integer(c_int), intent(in) :: code
            character(len=*), intent(in) :: text
            if (allocated(error)) return
            call check_status_code(error, int(code), HOLOSYM_INVALID_ARGUMENT, text)
            if (allocated(error)) return
            call check(error, index(message_of(handle), text) == 1, "message '" // &
                message_of(handle) // "', expected '" // text // "...'")
        end subroutine expect
    end subroutine null_arrays

    !> A destroyed handle, a handle destroyed twice and a pointer the library never
    !! returned: every call answers HOLOSYM_NOT_INITIALIZED without reading it, destroy
    !! ignores it, the message says what is wrong.
    subroutine dead_handles(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(holosym_system_c), target :: system
        type(c_ptr) :: handle, other
        real(c_real), target :: q(2), p(2), not_a_handle(64)
        integer :: k
        type(c_ptr) :: pointers(2)
        system = pendulum_struct()
        handle = holosym_create(c_loc(system), 3_c_int, 2_c_int, 4_c_int)
        other = holosym_create(c_loc(system), 3_c_int, 2_c_int, 4_c_int)
        call holosym_destroy(handle)
        call holosym_destroy(handle)          ! twice: ignored
        not_a_handle = 1
        pointers = [handle, c_loc(not_a_handle)]
        q = [sin(1.0_c_real), -cos(1.0_c_real)]
        p = 0
        do k = 1, 2
            call check_status_code(error, int(holosym_status(pointers(k))), &
                HOLOSYM_NOT_INITIALIZED, "status of a dead or foreign handle")
            if (allocated(error)) return
            call check_status_code(error, int(holosym_step(pointers(k), c_loc(q), c_loc(p), &
                0.0625_c_real)), HOLOSYM_NOT_INITIALIZED, "step on a dead or foreign handle")
            if (allocated(error)) return
            call check(error, index(message_of(pointers(k)), "not a live integrator") > 0, &
                "message: " // message_of(pointers(k)))
            if (allocated(error)) return
            call holosym_destroy(pointers(k))
        end do
        call check(error, all(not_a_handle == 1), "a foreign pointer is not written")
        if (allocated(error)) return
        call check_status_code(error, int(holosym_step(other, c_loc(q), c_loc(p), &
            0.0625_c_real)), HOLOSYM_SUCCESS, "the other handle still works")
        call holosym_destroy(other)
    end subroutine dead_handles

    !> include/holosym.h defines exactly the codes of the library's table, with their
    !! values, and docs/status-codes.md has a row for each with its short name.
    subroutine header_codes(error)
        type(test_error_t), allocatable, intent(out) :: error
        character(len=:), allocatable :: header, docs, row, value
        character(len=64) :: name
        integer :: k, start, finish, found, defined, code, io
        header = file_text("include/holosym.h")
        docs = file_text("docs/status-codes.md")
        defined = 0
        start = 1
        do
            found = index(header(start:), "#define HOLOSYM_")
            if (found == 0) exit
            start = start + found - 1 + len("#define ")
            finish = start + index(header(start:), new_line("a")) - 2
            row = header(start:finish)
            start = finish + 1
            if (index(row, "/*") > 0) row = row(:index(row, "/*") - 1)
            read (row, *, iostat=io) name
            if (name == "HOLOSYM_H" .or. index(name, "HOLOSYM_NAME_") == 1 .or. &
                index(name, "HOLOSYM_EVENT_") == 1) cycle
            value = adjustl(row(len_trim(name) + 1:))
            if (value(1:1) == "(") value = value(2:index(value, ")") - 1)
            read (value, *, iostat=io) code
            call check(error, io == 0, "header: no value in '" // trim(row) // "'")
            if (allocated(error)) return
            defined = defined + 1
            k = findloc(status_code_table%constant, name, dim=1)
            call check(error, k > 0, "header defines " // trim(name) // ", not in the table")
            if (allocated(error)) return
            call check(error, status_code_table(k)%code == code, "header: " // trim(name) // &
                " has another value than in the library")
            if (allocated(error)) return
        end do
        call check(error, defined == size(status_code_table), "header: codes missing")
        if (allocated(error)) return
        do k = 1, size(status_code_table)
            associate (entry => status_code_table(k))
                row = "| " // minus(entry%code) // " | `" // trim(entry%constant) // "` | " // &
                    trim(entry%name) // " |"
                call check(error, index(docs, row) > 0, "docs/status-codes.md: no row " // row)
                if (allocated(error)) return
            end associate
        end do
    contains
        !> The code as the docs write it (a minus sign, U+2212, for negatives).
        function minus(number) result(text)
            integer, intent(in) :: number
            character(len=:), allocatable :: text
            character(len=12) :: digits
            write (digits, '(i0)') abs(number)
            text = trim(digits)
            if (number < 0) text = char(226) // char(136) // char(146) // text
        end function minus
    end subroutine header_codes

    !> holosym_plan_accuracy on the four-bar model gives the plan of init_for_accuracy on
    !! the same Fortran model (h and steps, and then the same state at T, bit for bit);
    !! a bad request or a NULL pointer fails with the message, h and steps unchanged.
    subroutine plan_accuracy(error)
        type(test_error_t), allocatable, intent(out) :: error
        character(kind=c_char), allocatable, target :: text(:)
        type(c_ptr) :: handle
        type(formula_model) :: model
        type(constrained_integrator) :: integ
        type(accuracy_plan_t) :: plan
        type(holosym_status_t) :: status
        real(c_real), target :: q(4), p(4), tolerance, span, h
        real(wp) :: qf(4), pf(4)
        integer(c_int), target :: steps, done, orders(3)
        text = c_text(file_text("example/models/fourbar.hsm"))
        handle = holosym_model_create(c_loc(text), 2_c_int, 1_c_int, 3_c_int)
        call check_status_code(error, int(holosym_model_initial_state(handle, c_loc(q), &
            c_loc(p))), HOLOSYM_SUCCESS, message_of(handle))
        if (allocated(error)) return
        tolerance = merge(1.0e-10_c_real, 1.0e-20_c_real, wp_is_double)
        span = 2
        h = -1
        steps = -1
        call check_status_code(error, int(holosym_plan_accuracy(handle, c_loc(q), c_loc(p), &
            c_loc(tolerance), c_loc(span), c_loc(h), c_loc(steps), c_loc(orders))), &
            HOLOSYM_SUCCESS, message_of(handle))
        if (allocated(error)) return
        call load_model("example/models/fourbar.hsm", model, status)
        call model%initial_state(qf, pf, status)
        call init_for_accuracy(integ, model, qf, pf, real(tolerance, wp), real(span, wp), &
                               plan, status)
        call check(error, all(orders == [plan%order_m, plan%order_n, plan%gauss_points]), &
            "orders " // int_str(int(orders(1))) // " not the plan's")
        call check(error, status%ok() .and. h == plan%h .and. steps == plan%steps, &
            "the C plan (h " // real_str(real(h, wp)) // ", " // int_str(int(steps)) // &
            " steps) is not the Fortran one (h " // real_str(plan%h) // ", " // &
            int_str(plan%steps) // ")")
        call check_status_code(error, int(holosym_integrate(handle, c_loc(q), c_loc(p), h, &
            steps, c_null_funptr, c_null_ptr, c_loc(done))), HOLOSYM_SUCCESS, &
            message_of(handle))
        call integ%integrate(model, qf, pf, plan%h, plan%steps, status=status)
        call check(error, all(real(q, wp) == qf) .and. all(real(p, wp) == pf), &
            "the C run differs from the Fortran one")
        tolerance = 2
        call check_status_code(error, int(holosym_plan_accuracy(handle, c_loc(q), c_loc(p), &
            c_loc(tolerance), c_loc(span), c_loc(h), c_loc(steps), c_null_ptr)), &
            HOLOSYM_INVALID_ARGUMENT, "tolerance 2")
        call check(error, index(message_of(handle), "holosym_plan_accuracy: tolerance") > 0, &
            "message: " // message_of(handle))
        call check_status_code(error, int(holosym_plan_accuracy(handle, c_loc(q), c_loc(p), &
            c_null_ptr, c_loc(span), c_loc(h), c_loc(steps), c_null_ptr)), &
            HOLOSYM_INVALID_ARGUMENT, "NULL tolerance")
        call check(error, h == plan%h .and. steps == plan%steps, "h or steps changed by a " // &
            "failed call")
        call holosym_destroy(handle)
    end subroutine plan_accuracy

    !> The _p calls (reals through pointers) give the bits of the calls with values on the
    !! four-bar model; holosym_energy and holosym_constraint give H and phi of the Fortran
    !! model; the observer of holosym_integrate_p sees t = k h and stops the run; NULL
    !! pointers are refused with their names, the arrays unchanged.
    subroutine pointer_calls(error)
        type(test_error_t), allocatable, intent(out) :: error
        character(kind=c_char), allocatable, target :: text(:), name(:)
        type(c_ptr) :: by_value, by_pointer
        type(formula_model) :: model
        type(holosym_status_t) :: status
        real(c_real), target :: q1(4), p1(4), q2(4), p2(4), h, tau, value, energy, phi(3)
        real(c_real), target :: qd1(4), pd1(4), ld1(3), qd2(4), pd2(4), ld2(3), seen(8)
        real(wp) :: qf(4), pf(4), phif(3)
        integer(c_int), target :: done
        text = c_text(file_text("example/models/fourbar.hsm"))
        by_value = holosym_model_create(c_loc(text), 4_c_int, 3_c_int, 5_c_int)
        by_pointer = holosym_model_create(c_loc(text), 4_c_int, 3_c_int, 5_c_int)
        name = c_text("omega")
        value = 3
        call check_status_code(error, int(holosym_model_set_parameter(by_value, c_loc(name), &
            3.0_c_real)), HOLOSYM_SUCCESS, message_of(by_value))
        call check_status_code(error, int(holosym_model_set_parameter_p(by_pointer, &
            c_loc(name), c_loc(value))), HOLOSYM_SUCCESS, message_of(by_pointer))
        value = 0
        call check_status_code(error, int(holosym_model_get_parameter(by_pointer, c_loc(name), &
            c_loc(value))), HOLOSYM_SUCCESS, message_of(by_pointer))
        call check(error, value == 3, "omega set through a pointer reads back 3")
        if (allocated(error)) return
        call check_status_code(error, int(holosym_model_initial_state(by_value, c_loc(q1), &
            c_loc(p1))), HOLOSYM_SUCCESS, message_of(by_value))
        call check_status_code(error, int(holosym_model_initial_state(by_pointer, c_loc(q2), &
            c_loc(p2))), HOLOSYM_SUCCESS, message_of(by_pointer))
        h = 1.0_c_real / 32
        call check_status_code(error, int(holosym_step(by_value, c_loc(q1), c_loc(p1), h)), &
            HOLOSYM_SUCCESS, message_of(by_value))
        call check_status_code(error, int(holosym_step_p(by_pointer, c_loc(q2), c_loc(p2), &
            c_loc(h))), HOLOSYM_SUCCESS, message_of(by_pointer))
        call check(error, all(q1 == q2) .and. all(p1 == p2), "holosym_step_p differs")
        tau = 0.25_c_real
        call check_status_code(error, int(holosym_dense_output(by_value, tau, c_loc(qd1), &
            c_loc(pd1), c_loc(ld1))), HOLOSYM_SUCCESS, message_of(by_value))
        call check_status_code(error, int(holosym_dense_output_p(by_pointer, c_loc(tau), &
            c_loc(qd2), c_loc(pd2), c_loc(ld2))), HOLOSYM_SUCCESS, message_of(by_pointer))
        call check(error, all(qd1 == qd2) .and. all(pd1 == pd2) .and. all(ld1 == ld2), &
            "holosym_dense_output_p differs")
        if (allocated(error)) return
        call check_status_code(error, int(holosym_integrate(by_value, c_loc(q1), c_loc(p1), h, &
            3_c_int, c_null_funptr, c_null_ptr, c_loc(done))), HOLOSYM_SUCCESS, &
            message_of(by_value))
        seen = -1
        call check_status_code(error, int(holosym_integrate_p(by_pointer, c_loc(q2), &
            c_loc(p2), c_loc(h), 5_c_int, c_funloc(c_watch_p), c_loc(seen), c_loc(done))), &
            HOLOSYM_USER_ABORT, "the observer of holosym_integrate_p stops at step 3")
        call check(error, done == 3 .and. all(q1 == q2) .and. all(p1 == p2), &
            "holosym_integrate_p differs from holosym_integrate")
        call check(error, all(seen(1:3) == [1, 2, 3] * h) .and. seen(4) == -1, &
            "the observer's t through a pointer is k h")
        if (allocated(error)) return
        call load_model("example/models/fourbar.hsm", model, status)
        call model%set_parameter("omega", 3.0_wp)
        qf = q2
        pf = p2
        call model%constraint(qf, phif)
        call check_status_code(error, int(holosym_energy(by_pointer, c_loc(q2), c_loc(p2), &
            c_loc(energy))), HOLOSYM_SUCCESS, message_of(by_pointer))
        call check(error, energy == model%hamiltonian(qf, pf), "holosym_energy is not H")
        call check_status_code(error, int(holosym_constraint(by_pointer, c_loc(q2), &
            c_loc(phi))), HOLOSYM_SUCCESS, message_of(by_pointer))
        call check(error, all(phi == phif), "holosym_constraint is not phi")
        if (allocated(error)) return
        q1 = q2
        call check_status_code(error, int(holosym_step_p(by_pointer, c_loc(q2), c_loc(p2), &
            c_null_ptr)), HOLOSYM_INVALID_ARGUMENT, "NULL h")
        call check(error, message_of(by_pointer) == "holosym_step_p: h is NULL", &
            "message of a NULL h: " // message_of(by_pointer))
        call check(error, all(q1 == q2), "q changed by a refused call")
        call check_status_code(error, int(holosym_integrate_p(by_pointer, c_loc(q2), &
            c_loc(p2), c_null_ptr, 1_c_int, c_null_funptr, c_null_ptr, c_null_ptr)), &
            HOLOSYM_INVALID_ARGUMENT, "NULL h of integrate_p")
        call check_status_code(error, int(holosym_dense_output_p(by_pointer, c_null_ptr, &
            c_loc(qd2), c_loc(pd2), c_loc(ld2))), HOLOSYM_INVALID_ARGUMENT, "NULL tau")
        call check(error, message_of(by_pointer) == "holosym_dense_output_p: tau is NULL", &
            "message of a NULL tau: " // message_of(by_pointer))
        call check_status_code(error, int(holosym_model_set_parameter_p(by_pointer, &
            c_loc(name), c_null_ptr)), HOLOSYM_INVALID_ARGUMENT, "NULL value")
        call check_status_code(error, int(holosym_energy(by_pointer, c_loc(q2), c_loc(p2), &
            c_null_ptr)), HOLOSYM_INVALID_ARGUMENT, "NULL energy")
        call check_status_code(error, int(holosym_constraint(by_pointer, c_loc(q2), &
            c_null_ptr)), HOLOSYM_INVALID_ARGUMENT, "NULL phi")
        call check(error, message_of(by_pointer) == "holosym_constraint: phi is NULL (m > 0)", &
            "message of a NULL phi: " // message_of(by_pointer))
        call check_status_code(error, int(holosym_step_p(c_null_ptr, c_loc(q2), c_loc(p2), &
            c_loc(h))), HOLOSYM_NOT_INITIALIZED, "NULL handle")
        call check_status_code(error, int(holosym_energy(c_null_ptr, c_loc(q2), c_loc(p2), &
            c_loc(energy))), HOLOSYM_NOT_INITIALIZED, "NULL handle of holosym_energy")
        call holosym_destroy(by_value)
        call holosym_destroy(by_pointer)
    end subroutine pointer_calls

    !> holosym_integrate_events on the callback pendulum gives the events of the Fortran
    !! integrate_events on the built-in one (two passages of the vertical in 96 steps of
    !! 1/16 with (8, 7, 9), falling then rising, the same times and states within the
    !! scheme's accuracy); a terminal rising event ends the run at its state (*stopped =
    !! 1); a g that fails stops the run with HOLOSYM_NONFINITE_VALUE; a NULL g is refused.
    subroutine events_through_c(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(c_ptr) :: handle
        type(planar_pendulum) :: sys
        type(constrained_integrator) :: integ
        type(holosym_status_t) :: status
        type(event_t), allocatable :: found(:)
        type(holosym_system_c), target :: system
        real(c_real), target :: q(2), p(2), h, seen(16)
        real(wp) :: qf(2), pf(2), agreement
        integer(c_int), target :: done, stopped, rising(1), stops(1)
        logical :: ended
        integer :: j
        agreement = max(1.0e-29_wp, 1.0e4_wp * eps)
        sys = planar_pendulum()
        call sys%initial_state(qf, pf)
        call integ%init(sys, 8, 7, 9, status)
        call integrate_events(integ, sys, qf, pf, 1.0_wp / 16, 96, x_event(), found, ended, &
                              status)
        system = pendulum_struct()
        handle = holosym_create(c_loc(system), 8_c_int, 7_c_int, 9_c_int)
        call sys%initial_state(qf, pf)
        q = qf
        p = pf
        h = 1.0_c_real / 16
        seen = 0
        call check_status_code(error, int(holosym_integrate_events(handle, c_loc(q), c_loc(p), &
            c_loc(h), 96_c_int, 1_c_int, c_funloc(c_event_x), c_null_ptr, c_null_ptr, &
            c_funloc(c_event_seen), c_loc(seen), c_loc(done), c_loc(stopped))), &
            HOLOSYM_SUCCESS, message_of(handle))
        if (allocated(error)) return
        call check(error, nint(seen(1)) == 2 .and. size(found) == 2 .and. done == 96 .and. &
            stopped == 0, int_str(nint(seen(1))) // " events through C, " // &
            int_str(size(found)) // " in Fortran, " // int_str(int(done)) // " steps")
        if (allocated(error)) return
        do j = 1, 2
            call check(error, nint(seen(4 * j - 1)) == found(j)%direction .and. &
                abs(real(seen(4 * j), wp) - found(j)%t) <= agreement, "event " // &
                int_str(j) // ": t = " // real_str(real(seen(4 * j), wp)) // " through C, " &
                // real_str(found(j)%t) // " in Fortran")
        end do
        call sys%initial_state(qf, pf)
        q = qf
        p = pf
        seen = 0
        rising = 1
        stops = 1
        call check_status_code(error, int(holosym_integrate_events(handle, c_loc(q), c_loc(p), &
            c_loc(h), 96_c_int, 1_c_int, c_funloc(c_event_x), c_loc(rising), c_loc(stops), &
            c_funloc(c_event_seen), c_loc(seen), c_loc(done), c_loc(stopped))), &
            HOLOSYM_SUCCESS, message_of(handle))
        call check(error, stopped == 1 .and. nint(seen(1)) == 1 .and. nint(seen(3)) == 1 .and. &
            q(1) == seen(5) .and. abs(real(seen(4), wp) - found(2)%t) <= agreement, &
            "terminal rising event: stopped " // int_str(int(stopped)) // ", x " // &
            real_str(real(q(1), wp)) // " and " // real_str(real(seen(5), wp)))
        call sys%initial_state(qf, pf)
        q = qf
        p = pf
        seen(16) = -1
        call check_status_code(error, int(holosym_integrate_events(handle, c_loc(q), c_loc(p), &
            c_loc(h), 96_c_int, 1_c_int, c_funloc(c_event_x), c_null_ptr, c_null_ptr, &
            c_null_funptr, c_loc(seen), c_loc(done), c_null_ptr)), HOLOSYM_NONFINITE_VALUE, &
            "a failing g: " // message_of(handle))
        call check(error, done == 8, int_str(int(done)) // " steps before g failed at " // &
            "t = 0.5, expected 8")
        call check_status_code(error, int(holosym_integrate_events(handle, c_loc(q), c_loc(p), &
            c_loc(h), 96_c_int, 1_c_int, c_null_funptr, c_null_ptr, c_null_ptr, &
            c_null_funptr, c_null_ptr, c_null_ptr, c_null_ptr)), HOLOSYM_INVALID_ARGUMENT, &
            "NULL g")
        call holosym_destroy(handle)
    end subroutine events_through_c

    !> holosym_lyapunov_spectrum on the planar pendulum of C callbacks gives the spectrum,
    !! MEGNO and end state of lyapunov_spectrum on the built-in twin; NULL exponents are
    !! refused with the state unchanged.
    subroutine lyapunov_through_c(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(c_ptr) :: handle
        type(planar_pendulum) :: sys
        type(constrained_integrator) :: integ
        type(lyapunov_result_t) :: fortran
        type(holosym_status_t) :: status
        type(holosym_system_c), target :: system
        real(c_real), target :: q(2), p(2), h, exponents(2), megno, q0(2)
        real(wp) :: qf(2), pf(2), agreement
        integer(c_int), target :: done
        agreement = max(1.0e-29_wp, 1.0e4_wp * eps)
        sys = planar_pendulum()
        call sys%initial_state(qf, pf)
        call integ%init(sys, 4, 3, 5, status)
        call lyapunov_spectrum(integ, sys, qf, pf, 0.125_wp, 200, fortran, status)
        system = pendulum_struct()
        handle = holosym_create(c_loc(system), 4_c_int, 3_c_int, 5_c_int)
        call sys%initial_state(qf, pf)
        q = qf
        p = pf
        q0 = q
        h = 0.125_c_real
        call check_status_code(error, int(holosym_lyapunov_spectrum(handle, c_loc(q), c_loc(p), &
            c_loc(h), 0_c_int, c_null_ptr, c_loc(megno), c_loc(done))), &
            HOLOSYM_INVALID_ARGUMENT, "NULL exponents")
        if (allocated(error)) return
        call check(error, all(q == q0), "the state moved")
        if (allocated(error)) return
        call check_status_code(error, int(holosym_lyapunov_spectrum(handle, c_loc(q), c_loc(p), &
            c_loc(h), 200_c_int, c_loc(exponents), c_loc(megno), c_loc(done))), &
            HOLOSYM_SUCCESS, message_of(handle))
        if (allocated(error)) return
        call check(error, status%ok() .and. done == 200 .and. &
            maxval(abs(real(exponents, wp) - fortran%exponents)) <= agreement .and. &
            abs(real(megno, wp) - fortran%megno) <= agreement .and. &
            maxval(abs(real(q, wp) - qf)) > 0.1_wp, "through C " // &
            real_str(real(exponents(1), wp)) // ", in Fortran " // real_str(fortran%exponents(1)))
        call holosym_destroy(handle)
    end subroutine lyapunov_through_c

    !> The tangent calls on the planar pendulum of C callbacks: the basis of the tangent
    !! space and 20 steps of the tangent map as in Fortran on the built-in twin (general
    !! scheme, as for callbacks), the symplectic form of the two images kept to round-off,
    !! a vector off the tangent space refused with everything unchanged and accepted once
    !! projected, k = 0 and NULL vectors refused.
    subroutine tangent_through_c(error)
        type(test_error_t), allocatable, intent(out) :: error
        type(c_ptr) :: handle
        type(planar_pendulum) :: sys
        type(constrained_integrator) :: integ
        type(holosym_status_t) :: status
        type(holosym_system_c), target :: system
        real(c_real), target :: q(2), p(2), h, dq(2, 2), dp(2, 2), rq(2), rp(2), q0(2), p0(2)
        real(wp) :: qf(2), pf(2), dqf(2, 2), dpf(2, 2), form0, agreement
        integer(c_int), target :: count
        integer :: k, nf
        agreement = max(1.0e-29_wp, 1.0e4_wp * eps)
        sys = planar_pendulum()
        call sys%initial_state(qf, pf)
        system = pendulum_struct()
        handle = holosym_create(c_loc(system), 4_c_int, 3_c_int, 5_c_int)
        q = qf
        p = pf
        h = 0.125_c_real
        call check_status_code(error, int(holosym_tangent_basis(handle, c_loc(q), c_loc(p), &
            c_loc(dq), c_loc(dp), c_loc(count))), HOLOSYM_SUCCESS, message_of(handle))
        if (allocated(error)) return
        call tangent_basis(sys, qf, pf, dqf, dpf, nf, status)
        call check(error, count == 2 .and. nf == 2 .and. &
            max(maxval(abs(real(dq, wp) - dqf)), maxval(abs(real(dp, wp) - dpf))) <= agreement, &
            "the basis through C differs from tangent_basis")
        if (allocated(error)) return
        form0 = symplectic_form(real(dq, wp), real(dp, wp))
        call check(error, abs(form0) > 0.1_wp, "the basis spans no symplectic pair")
        if (allocated(error)) return
        ! A radial direction leaves the circle: refused, nothing moves.
        rq = q
        rp = 0
        q0 = q
        p0 = p
        call check_status_code(error, int(holosym_step_tangent(handle, c_loc(q), c_loc(p), &
            c_loc(h), 1_c_int, c_loc(rq), c_loc(rp))), HOLOSYM_OFF_MANIFOLD, "radial vector")
        if (allocated(error)) return
        call check(error, all(q == q0) .and. all(p == p0) .and. all(rq == q0) .and. &
            all(rp == 0), "a refused call changed its arguments")
        if (allocated(error)) return
        call check_status_code(error, int(holosym_project_tangent(handle, c_loc(q), c_loc(p), &
            1_c_int, c_loc(rq), c_loc(rp))), HOLOSYM_SUCCESS, message_of(handle))
        if (allocated(error)) return
        call check(error, tangent_residual(sys, qf, pf, real(rq, wp), real(rp, wp)) <= &
            tangent_tolerance, "the projected vector is not tangent")
        call check_status_code(error, int(holosym_step_tangent(handle, c_loc(q), c_loc(p), &
            c_loc(h), 0_c_int, c_loc(dq), c_loc(dp))), HOLOSYM_INVALID_ARGUMENT, "k = 0")
        call check_status_code(error, int(holosym_step_tangent(handle, c_loc(q), c_loc(p), &
            c_loc(h), 2_c_int, c_null_ptr, c_loc(dp))), HOLOSYM_INVALID_ARGUMENT, "NULL dq")
        if (allocated(error)) return
        integ%structured = .false.
        call integ%init(sys, 4, 3, 5, status)
        do k = 1, 20
            call check_status_code(error, int(holosym_step_tangent(handle, c_loc(q), c_loc(p), &
                c_loc(h), 2_c_int, c_loc(dq), c_loc(dp))), HOLOSYM_SUCCESS, message_of(handle))
            if (allocated(error)) return
            call integ%step_tangent(sys, qf, pf, 0.125_wp, dqf, dpf, status=status)
        end do
        call check(error, status%ok() .and. max(maxval(abs(real(dq, wp) - dqf)), &
            maxval(abs(real(dp, wp) - dpf)), maxval(abs(real(q, wp) - qf))) <= agreement, &
            "the tangent map through C differs from step_tangent")
        if (allocated(error)) return
        call check(error, abs(symplectic_form(real(dq, wp), real(dp, wp)) - form0) <= &
            1.0e3_wp * eps, "symplectic form " // real_str(form0) // " became " // &
            real_str(symplectic_form(real(dq, wp), real(dp, wp))))
        call holosym_destroy(handle)
    contains
        !> omega(u1, u2) = dq1 . dp2 - dp1 . dq2 of the first two vectors.
        pure real(wp) function symplectic_form(vq, vp) result(omega)
            real(wp), intent(in) :: vq(:, :), vp(:, :)
            omega = dot_product(vq(:, 1), vp(:, 2)) - dot_product(vp(:, 1), vq(:, 2))
        end function symplectic_form
    end subroutine tangent_through_c

    integer function x_event_count(self)
        class(x_event), intent(in) :: self
        x_event_count = 1
    end function x_event_count

    real(wp) function x_event_value(self, k, t, q, p) result(g)
        class(x_event), intent(in) :: self
        integer, intent(in) :: k
        real(wp), intent(in) :: t, q(:), p(:)
        g = q(1)
    end function x_event_value

end module test_capi
