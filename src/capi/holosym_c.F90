!> category: C interface (include/holosym.h)
!! The C interface of holosym (declared in include/holosym.h): an integrator for a system
!! given by C callbacks, with step, integrate (with an optional C observer), dense output,
!! projection onto the manifold, status code and message.
!!
!! Reals are `holosym_real`: `__float128` in the default (real128) build, through
!! gfortran's `c_float128` (a GNU extension of ISO_C_BINDING; the C side needs a compiler
!! with `__float128`, e.g. GCC or Clang on x86-64), and `double` in the real64 build
!! (-DHOLOSYM_REAL64), where any C compiler works.
!!
!! A handle owns the integrator, a copy of the callbacks and the status of its last call.
!! Every function returns that status code (0 success, < 0 invalid input, > 0 numerical
!! failure: the HOLOSYM_* codes) and keeps the caller's arrays unchanged on failure. A
!! callback returns 0 on success; any other value refuses the point (`refuse`): the call
!! that needed the value fails with HOLOSYM_OUTSIDE_DOMAIN, its message names the callback
!! and the value it returned, and the values the callback wrote are not used.
!!
!! A real128 build with a compiler other than gfortran has no C kind for the library's
!! reals: the module then holds only `c_interface_available = .false.`.

module holosym_c
#if defined(HOLOSYM_REAL64) || defined(__GFORTRAN__)
    use, intrinsic :: iso_c_binding, only: c_int, c_char, c_ptr, c_funptr, c_null_ptr, &
        c_null_char, c_associated, c_f_pointer, c_f_procpointer, c_loc, c_double, c_size_t
#ifndef HOLOSYM_REAL64
    use, intrinsic :: iso_c_binding, only: c_float128
#endif
    use, intrinsic :: ieee_arithmetic, only: ieee_is_finite, ieee_value, ieee_quiet_nan
    use holosym_kinds, only: wp
    use holosym_status_codes, only: holosym_status_t, HOLOSYM_SUCCESS, &
        HOLOSYM_INVALID_ARGUMENT, HOLOSYM_NOT_INITIALIZED, HOLOSYM_INVALID_DIMENSION, &
        HOLOSYM_NONFINITE_VALUE
    use holosym_problem, only: constrained_hamiltonian, clear_refusal, check_refusal
    use holosym_formula_model, only: formula_model, model_from_text
    use holosym_integrator, only: constrained_integrator, step_observer, step_info_t
    use holosym_accuracy, only: accuracy_plan_t, init_for_accuracy
    use holosym_events, only: event_set, event_t, integrate_events
    use holosym_lyapunov, only: lyapunov_spectrum, lyapunov_result_t
    use holosym_projection, only: project_to_manifold
    use holosym_tangent_space, only: tangent_basis, project_tangent
    use holosym_c_registry, only: register_handle, forget_handle, is_live_handle
    implicit none
    private

    public :: holosym_system_c, c_real
    !> True: this build has the C interface.
    logical, parameter, public :: c_interface_available = .true.
    public :: holosym_create, holosym_destroy, holosym_status, holosym_message, holosym_step, &
        holosym_integrate, holosym_dense_output, holosym_project, holosym_sizes
    public :: holosym_model_create, holosym_model_set_parameter, holosym_model_get_parameter, &
        holosym_model_initial_state, holosym_model_parameter_count, holosym_model_name
    ! Reals through pointers (for callers that cannot pass __float128 by value, e.g.
    ! Python's ctypes), and H and phi at a state.
    public :: holosym_step_p, holosym_integrate_p, holosym_dense_output_p, &
        holosym_model_set_parameter_p, holosym_energy, holosym_constraint
    ! The trade of speed for accuracy as one argument.
    public :: holosym_plan_accuracy
    ! Events: zero crossings of functions of the motion.
    public :: holosym_integrate_events, holosym_lyapunov_spectrum
    ! The tangent map of a step, and the tangent space it acts on.
    public :: holosym_step_tangent, holosym_tangent_basis, holosym_project_tangent

    !> What `holosym_model_name` names (HOLOSYM_NAME_* in the header).
    integer(c_int), parameter, public :: name_parameter_c = 0, name_coordinate_c = 1, &
        name_momentum_c = 2

#ifdef HOLOSYM_REAL64
    !> The C type of reals: double.
    integer, parameter :: c_real = c_double
#else
    !> The C type of reals: __float128.
    integer, parameter :: c_real = c_float128
#endif
    ! The C real must be the library's real (fails to compile otherwise).
    integer, parameter :: kinds_agree(1) = [1]
    integer, parameter :: kinds_check = kinds_agree(merge(1, 2, c_real == wp))

    !> The system as C gives it (struct holosym_system).
    type, bind(C) :: holosym_system_c
        integer(c_int) :: n = 0                  !! coordinates
        integer(c_int) :: m = 0                  !! constraints
        type(c_funptr) :: hamiltonian            !! int (*)(int n, q, p, *energy, data)
        type(c_funptr) :: dh_dq                  !! int (*)(int n, q, p, grad, data)
        type(c_funptr) :: dh_dp                  !! int (*)(int n, q, p, grad, data)
        type(c_funptr) :: constraint             !! int (*)(int n, int m, q, phi, data)
        type(c_funptr) :: constraint_jacobian    !! int (*)(int n, int m, q, jac, data)
        type(c_ptr) :: data                      !! passed to every callback
    end type holosym_system_c

    interface
        !> The C library's strlen.
        function c_strlen(text) result(length) bind(C, name="strlen")
            import :: c_ptr, c_size_t
            type(c_ptr), value :: text
            integer(c_size_t) :: length
        end function c_strlen
    end interface

    abstract interface
        integer(c_int) function c_hamiltonian(n, q, p, energy, data) bind(C)
            import :: c_int, c_real, c_ptr
            integer(c_int), value :: n
            real(c_real), intent(in) :: q(*), p(*)
            real(c_real), intent(out) :: energy
            type(c_ptr), value :: data
        end function c_hamiltonian
        integer(c_int) function c_gradient(n, q, p, gradient, data) bind(C)
            import :: c_int, c_real, c_ptr
            integer(c_int), value :: n
            real(c_real), intent(in) :: q(*), p(*)
            real(c_real), intent(out) :: gradient(*)
            type(c_ptr), value :: data
        end function c_gradient
        integer(c_int) function c_constraint(n, m, q, values, data) bind(C)
            import :: c_int, c_real, c_ptr
            integer(c_int), value :: n, m
            real(c_real), intent(in) :: q(*)
            real(c_real), intent(out) :: values(*)
            type(c_ptr), value :: data
        end function c_constraint
        integer(c_int) function c_observer(handle, step, t, q, p, data) bind(C)
            import :: c_int, c_real, c_ptr
            type(c_ptr), value :: handle
            integer(c_int), value :: step
            real(c_real), value :: t
            real(c_real), intent(in) :: q(*), p(*)
            type(c_ptr), value :: data
        end function c_observer
        !> An event function of `holosym_integrate_events`: g_k(t, q, p) into value; any
        !! return other than 0: it cannot be evaluated there.
        integer(c_int) function c_event_function(k, t, q, p, value, data) bind(C)
            import :: c_int, c_real, c_ptr
            integer(c_int), value :: k
            real(c_real), intent(in) :: t
            real(c_real), intent(in) :: q(*), p(*)
            real(c_real), intent(out) :: value
            type(c_ptr), value :: data
        end function c_event_function
        !> Receives each event `holosym_integrate_events` located, in time order; any return
        !! other than 0: no further events are passed.
        integer(c_int) function c_event_found(k, direction, t, q, p, lambda, data) bind(C)
            import :: c_int, c_real, c_ptr
            integer(c_int), value :: k, direction
            real(c_real), intent(in) :: t
            real(c_real), intent(in) :: q(*), p(*), lambda(*)
            type(c_ptr), value :: data
        end function c_event_found
        !> The observer of `holosym_integrate_p`: t through a pointer.
        integer(c_int) function c_observer_p(handle, step, t, q, p, data) bind(C)
            import :: c_int, c_real, c_ptr
            type(c_ptr), value :: handle
            integer(c_int), value :: step
            real(c_real), intent(in) :: t
            real(c_real), intent(in) :: q(*), p(*)
            type(c_ptr), value :: data
        end function c_observer_p
    end interface

    !> The first callback failure of a call (kept through a pointer: the system's bindings
    !! see the system as intent(in)).
    type :: callback_record
        integer :: code = 0
        character(len=:), allocatable :: name
    end type callback_record

    !> A constrained Hamiltonian system whose procedures are C callbacks.
    type, extends(constrained_hamiltonian) :: c_callback_system
        procedure(c_hamiltonian), pointer, nopass :: h_fn => null()
        procedure(c_gradient), pointer, nopass :: hq_fn => null()
        procedure(c_gradient), pointer, nopass :: hp_fn => null()
        procedure(c_constraint), pointer, nopass :: phi_fn => null()
        procedure(c_constraint), pointer, nopass :: jac_fn => null()
        type(c_ptr) :: data = c_null_ptr
        type(callback_record), pointer :: record => null()
    contains
        procedure :: hamiltonian => c_system_hamiltonian
        procedure :: dh_dq => c_system_dh_dq
        procedure :: dh_dp => c_system_dh_dp
        procedure :: constraint => c_system_constraint
        procedure :: constraint_jacobian => c_system_constraint_jacobian
    end type c_callback_system

    !> Calls a C observer after every step of `holosym_integrate` (fn) or
    !! `holosym_integrate_p` (fn_p, t through a pointer).
    type, extends(step_observer) :: c_step_observer
        procedure(c_observer), pointer, nopass :: fn => null()
        procedure(c_observer_p), pointer, nopass :: fn_p => null()
        type(c_ptr) :: handle = c_null_ptr
        type(c_ptr) :: data = c_null_ptr
    contains
        procedure :: observe => c_observe
    end type c_step_observer

    !> The event functions of `holosym_integrate_events`: a C callback with its
    !! directions and terminal flags (arrays of `count`, or defaults when NULL).
    type, extends(event_set) :: c_event_set
        procedure(c_event_function), pointer, nopass :: fn => null()
        integer :: functions = 0
        integer(c_int), allocatable :: directions(:), stops(:)
        type(c_ptr) :: data = c_null_ptr
    contains
        procedure :: count => c_event_count
        procedure :: value => c_event_value
        procedure :: direction => c_event_direction
        procedure :: terminal => c_event_terminal
    end type c_event_set

    !> What a C handle points to: the integrator and its system, C callbacks
    !! (`holosym_create`) or a model (`holosym_model_create`).
    type :: c_handle
        type(constrained_integrator) :: integrator
        class(constrained_hamiltonian), allocatable :: system
        type(callback_record), pointer :: record => null()
        logical :: ready = .false.
        integer :: code = HOLOSYM_SUCCESS
        character(len=:), allocatable :: message
        !> (M, N, G) of the creation, for the integrator's new set-up after a parameter of
        !! a model changed.
        integer(c_int) :: orders(3) = 0
    end type c_handle

contains

    ! ---------------------------------------------------------------- the callbacks

    !> Remember the first failing callback of the current call, and refuse its point (the
    !! values it returns to the library are then zeros, never used).
    subroutine note_failure(self, name, code)
        class(c_callback_system), intent(in) :: self
        character(len=*), intent(in) :: name
        integer(c_int), intent(in) :: code
        call self%refuse("a callback returned non-zero")
        if (.not. associated(self%record)) return
        if (self%record%code /= 0) return
        self%record%code = code
        self%record%name = name
    end subroutine note_failure

    function c_system_hamiltonian(self, q, p) result(energy)
        class(c_callback_system), intent(in) :: self
        real(wp), intent(in) :: q(:), p(:)
        real(wp) :: energy
        real(c_real) :: q_c(self%n), p_c(self%n), value
        integer(c_int) :: rc
        q_c = q
        p_c = p
        rc = self%h_fn(int(self%n, c_int), q_c, p_c, value, self%data)
        energy = value
        if (rc /= 0) then
            call note_failure(self, "hamiltonian", rc)
            energy = 0
        end if
    end function c_system_hamiltonian

    subroutine c_system_dh_dq(self, q, p, gradient)
        class(c_callback_system), intent(in) :: self
        real(wp), intent(in) :: q(:), p(:)
        real(wp), intent(out) :: gradient(:)
        real(c_real) :: q_c(self%n), p_c(self%n), g_c(self%n)
        integer(c_int) :: rc
        q_c = q
        p_c = p
        rc = self%hq_fn(int(self%n, c_int), q_c, p_c, g_c, self%data)
        gradient = g_c
        if (rc /= 0) then
            call note_failure(self, "dh_dq", rc)
            gradient = 0
        end if
    end subroutine c_system_dh_dq

    subroutine c_system_dh_dp(self, q, p, gradient)
        class(c_callback_system), intent(in) :: self
        real(wp), intent(in) :: q(:), p(:)
        real(wp), intent(out) :: gradient(:)
        real(c_real) :: q_c(self%n), p_c(self%n), g_c(self%n)
        integer(c_int) :: rc
        q_c = q
        p_c = p
        rc = self%hp_fn(int(self%n, c_int), q_c, p_c, g_c, self%data)
        gradient = g_c
        if (rc /= 0) then
            call note_failure(self, "dh_dp", rc)
            gradient = 0
        end if
    end subroutine c_system_dh_dp

    subroutine c_system_constraint(self, q, phi)
        class(c_callback_system), intent(in) :: self
        real(wp), intent(in) :: q(:)
        real(wp), intent(out) :: phi(:)
        real(c_real) :: q_c(self%n), phi_c(max(1, self%m))
        integer(c_int) :: rc
        q_c = q
        rc = self%phi_fn(int(self%n, c_int), int(self%m, c_int), q_c, phi_c, self%data)
        phi = phi_c(1:self%m)
        if (rc /= 0) then
            call note_failure(self, "constraint", rc)
            phi = 0
        end if
    end subroutine c_system_constraint

    !> Phi from the row-major m x n array of C: jac[l n + i] = d phi_l / d q_i.
    subroutine c_system_constraint_jacobian(self, q, jacobian)
        class(c_callback_system), intent(in) :: self
        real(wp), intent(in) :: q(:)
        real(wp), intent(out) :: jacobian(:, :)
        real(c_real) :: q_c(self%n), jac_c(max(1, self%m * self%n))
        integer(c_int) :: rc
        integer :: l
        q_c = q
        rc = self%jac_fn(int(self%n, c_int), int(self%m, c_int), q_c, jac_c, self%data)
        do l = 1, self%m
            jacobian(l, :) = jac_c((l - 1) * self%n + 1:l * self%n)
        end do
        if (rc /= 0) then
            call note_failure(self, "constraint_jacobian", rc)
            jacobian = 0
        end if
    end subroutine c_system_constraint_jacobian

    subroutine c_observe(self, step, t, q, p, info, halt)
        class(c_step_observer), intent(inout) :: self
        integer, intent(in) :: step
        real(wp), intent(in) :: t, q(:), p(:)
        type(step_info_t), intent(in) :: info
        logical, intent(inout) :: halt
        real(c_real) :: q_c(size(q)), p_c(size(p)), t_c
        q_c = q
        p_c = p
        t_c = real(t, c_real)
        if (associated(self%fn_p)) then
            if (self%fn_p(self%handle, int(step, c_int), t_c, q_c, p_c, self%data) /= 0) &
                halt = .true.
        else
            if (self%fn(self%handle, int(step, c_int), t_c, q_c, p_c, self%data) /= 0) &
                halt = .true.
        end if
    end subroutine c_observe

    integer function c_event_count(self)
        class(c_event_set), intent(in) :: self
        c_event_count = self%functions
    end function c_event_count

    !> g_k from the callback; NaN where it returns non-zero (the run then stops with
    !! HOLOSYM_NONFINITE_VALUE naming the function).
    real(wp) function c_event_value(self, k, t, q, p) result(g)
        class(c_event_set), intent(in) :: self
        integer, intent(in) :: k
        real(wp), intent(in) :: t, q(:), p(:)
        real(c_real) :: t_c, q_c(size(q)), p_c(size(p)), value
        t_c = t
        q_c = q
        p_c = p
        value = 0
        if (self%fn(int(k, c_int), t_c, q_c, p_c, value, self%data) /= 0) then
            g = ieee_value(g, ieee_quiet_nan)
        else
            g = value
        end if
    end function c_event_value

    integer function c_event_direction(self, k)
        class(c_event_set), intent(in) :: self
        integer, intent(in) :: k
        c_event_direction = 0
        if (allocated(self%directions)) c_event_direction = self%directions(k)
    end function c_event_direction

    logical function c_event_terminal(self, k)
        class(c_event_set), intent(in) :: self
        integer, intent(in) :: k
        c_event_terminal = .false.
        if (allocated(self%stops)) c_event_terminal = self%stops(k) /= 0
    end function c_event_terminal

    ! ---------------------------------------------------------------- helpers

    !> The handle behind a C pointer: null unless it is a live handle (not NULL, not
    !! destroyed, returned by a create; see holosym_c_registry).
    function handle_of(ptr) result(handle)
        type(c_ptr), intent(in) :: ptr
        type(c_handle), pointer :: handle
        handle => null()
        if (is_live_handle(ptr)) call c_f_pointer(ptr, handle)
    end function handle_of

    !> A new live handle with an empty status, and its C pointer.
    function new_handle(handle) result(ptr)
        type(c_handle), pointer, intent(out) :: handle
        type(c_ptr) :: ptr
        allocate (handle)
        allocate (handle%record)
        handle%message = ""
        ptr = c_loc(handle)
        call register_handle(ptr)
    end function new_handle

    !> The handle behind `ptr` when it is live and was created successfully; otherwise
    !! null, with `code` HOLOSYM_NOT_INITIALIZED (and the handle's status when live).
    !! `caller` names the C function in the message.
    function ready_handle(ptr, caller, code) result(handle)
        type(c_ptr), intent(in) :: ptr
        character(len=*), intent(in) :: caller
        integer(c_int), intent(out) :: code
        type(c_handle), pointer :: handle
        handle => handle_of(ptr)
        code = int(HOLOSYM_NOT_INITIALIZED, c_int)
        if (.not. associated(handle)) return
        if (.not. handle%ready) then
            code = refuse(handle, HOLOSYM_NOT_INITIALIZED, caller // ": the integrator " // &
                "was not created successfully")
            handle => null()
            return
        end if
        code = int(HOLOSYM_SUCCESS, c_int)
    end function ready_handle

    !> Whether the arrays q and p of a call are given: a NULL one fails the call with
    !! HOLOSYM_INVALID_ARGUMENT naming `caller` and the argument (`code`).
    logical function arrays_given(handle, caller, q_ptr, p_ptr, code) result(given)
        type(c_handle), intent(inout) :: handle
        character(len=*), intent(in) :: caller
        type(c_ptr), intent(in) :: q_ptr, p_ptr
        integer(c_int), intent(out) :: code
        given = c_associated(q_ptr) .and. c_associated(p_ptr)
        code = int(HOLOSYM_SUCCESS, c_int)
        if (.not. c_associated(q_ptr)) then
            code = refuse(handle, HOLOSYM_INVALID_ARGUMENT, caller // ": q is NULL")
        else if (.not. c_associated(p_ptr)) then
            code = refuse(handle, HOLOSYM_INVALID_ARGUMENT, caller // ": p is NULL")
        end if
    end function arrays_given

    !> *address = value, unless address is NULL (an optional int output of a call).
    subroutine put_int(address, value)
        type(c_ptr), intent(in) :: address
        integer, intent(in) :: value
        integer(c_int), pointer :: target_int
        if (.not. c_associated(address)) return
        call c_f_pointer(address, target_int)
        target_int = int(value, c_int)
    end subroutine put_int

    !> The `count` reals at a C address that is not NULL.
    function reals_at(address, count) result(values)
        type(c_ptr), intent(in) :: address
        integer, intent(in) :: count
        real(c_real), pointer :: values(:)
        call c_f_pointer(address, values, [count])
    end function reals_at

    !> The k vectors of n reals stored one after another at a C address that is not NULL,
    !! as the columns of an n-by-k array.
    function vectors_at(address, n, k) result(vectors)
        type(c_ptr), intent(in) :: address
        integer, intent(in) :: n, k
        real(c_real), pointer :: vectors(:, :)
        call c_f_pointer(address, vectors, [n, k])
    end function vectors_at

    !> Record a call's outcome in the handle, adding the failing callback if any.
    integer(c_int) function finish(handle, status) result(code)
        type(c_handle), intent(inout) :: handle
        type(holosym_status_t), intent(in) :: status
        handle%code = status%code
        handle%message = ""
        if (allocated(status%message)) handle%message = status%message
        if (handle%record%code /= 0) handle%message = handle%message // " (callback " // &
            handle%record%name // " returned " // decimal(handle%record%code) // ")"
        code = int(handle%code, c_int)
    end function finish

    !> Fail a call on the handle before the library is reached.
    integer(c_int) function refuse(handle, code, message) result(result_code)
        type(c_handle), intent(inout) :: handle
        integer, intent(in) :: code
        character(len=*), intent(in) :: message
        handle%code = code
        handle%message = message
        result_code = int(code, c_int)
    end function refuse

    !> Decimal text of an integer.
    function decimal(value) result(text)
        integer, intent(in) :: value
        character(len=:), allocatable :: text
        character(len=16) :: buffer
        write (buffer, '(i0)') value
        text = trim(buffer)
    end function decimal

    !> The message of bad sizes.
    function dimension_message(n, m) result(text)
        integer, intent(in) :: n, m
        character(len=:), allocatable :: text
        character(len=32) :: numbers
        write (numbers, '(i0, ", m = ", i0)') n, m
        text = "holosym_create: need n >= 1 and 0 <= m < n; got n = " // trim(numbers)
    end function dimension_message

    ! ---------------------------------------------------------------- the C functions

    !> holosym_integrator *holosym_create(const holosym_system *system, int M, int N, int G):
    !! a handle for `system` and the scheme (M, N, G). Returns NULL only when `system` is
    !! NULL; otherwise check `holosym_status` (HOLOSYM_INVALID_ARGUMENT for a NULL callback,
    !! HOLOSYM_INVALID_DIMENSION, HOLOSYM_INVALID_ORDER). A handle whose creation failed
    !! answers every call with HOLOSYM_NOT_INITIALIZED until destroyed.
    function holosym_create(system_ptr, order_m, order_n, gauss_points) result(ptr) &
        bind(C, name="holosym_create")
        type(c_ptr), value :: system_ptr       !! const holosym_system *: the callbacks
        integer(c_int), value :: order_m       !! M >= 1
        integer(c_int), value :: order_n       !! N >= 0
        integer(c_int), value :: gauss_points  !! G >= N + 1
        type(c_ptr) :: ptr
        type(holosym_system_c), pointer :: system
        type(c_handle), pointer :: handle
        type(c_callback_system) :: callbacks
        type(holosym_status_t) :: status
        integer(c_int) :: ignored
        integer :: n, m
        ptr = c_null_ptr
        if (.not. c_associated(system_ptr)) return
        call c_f_pointer(system_ptr, system)
        ptr = new_handle(handle)
        if (.not. (c_associated(system%hamiltonian) .and. c_associated(system%dh_dq) .and. &
                   c_associated(system%dh_dp) .and. c_associated(system%constraint) .and. &
                   c_associated(system%constraint_jacobian))) then
            ignored = refuse(handle, HOLOSYM_INVALID_ARGUMENT, "holosym_create: every " // &
                "callback (hamiltonian, dh_dq, dh_dp, constraint, constraint_jacobian) must " &
                // "be given")
            return
        end if
        n = system%n
        m = system%m
        if (n < 1 .or. m < 0 .or. m >= n) then
            ignored = refuse(handle, HOLOSYM_INVALID_DIMENSION, dimension_message(n, m))
            return
        end if
        callbacks%n = system%n
        callbacks%m = system%m
        call c_f_procpointer(system%hamiltonian, callbacks%h_fn)
        call c_f_procpointer(system%dh_dq, callbacks%hq_fn)
        call c_f_procpointer(system%dh_dp, callbacks%hp_fn)
        call c_f_procpointer(system%constraint, callbacks%phi_fn)
        call c_f_procpointer(system%constraint_jacobian, callbacks%jac_fn)
        callbacks%data = system%data
        callbacks%record => handle%record
        allocate (handle%system, source=callbacks)
        call init_integrator(handle, order_m, order_n, gauss_points)
    end function holosym_create

    !> Set up the handle's integrator for its system and (M, N, G); the outcome is the
    !! handle's status.
    subroutine init_integrator(handle, order_m, order_n, gauss_points)
        type(c_handle), intent(inout) :: handle
        integer(c_int), intent(in) :: order_m, order_n, gauss_points
        type(holosym_status_t) :: status
        integer(c_int) :: ignored
        handle%orders = [order_m, order_n, gauss_points]
        call handle%integrator%init(handle%system, int(order_m), int(order_n), &
                                    int(gauss_points), status)
        handle%ready = status%code == HOLOSYM_SUCCESS
        ignored = finish(handle, status)
    end subroutine init_integrator

    !> void holosym_destroy(holosym_integrator *integrator): free the handle (NULL, a
    !! handle destroyed already and a pointer that is no handle are ignored).
    subroutine holosym_destroy(ptr) bind(C, name="holosym_destroy")
        type(c_ptr), value :: ptr !! the handle
        type(c_handle), pointer :: handle
        ! Forgetting is the lookup: one step under the registry's lock, so two destroys of
        ! one handle on two threads free it once.
        if (.not. forget_handle(ptr)) return
        call c_f_pointer(ptr, handle)
        if (associated(handle%record)) deallocate (handle%record)
        deallocate (handle)
    end subroutine holosym_destroy

    !> int holosym_status(const holosym_integrator *integrator): the code of the last call
    !! (HOLOSYM_NOT_INITIALIZED for NULL, a destroyed handle or a pointer that is none).
    integer(c_int) function holosym_status(ptr) bind(C, name="holosym_status")
        type(c_ptr), value :: ptr !! the handle
        type(c_handle), pointer :: handle
        handle => handle_of(ptr)
        holosym_status = int(HOLOSYM_NOT_INITIALIZED, c_int)
        if (associated(handle)) holosym_status = int(handle%code, c_int)
    end function holosym_status

    !> int holosym_message(const holosym_integrator *integrator, char *buffer, int size):
    !! copy the message of the last call into buffer (NUL-terminated, truncated to size - 1
    !! characters; nothing is copied when buffer is NULL or size < 1); returns the
    !! message's full length.
    integer(c_int) function holosym_message(ptr, buffer, size) bind(C, name="holosym_message")
        type(c_ptr), value :: ptr     !! the handle
        type(c_ptr), value :: buffer  !! char *: the message, or NULL
        integer(c_int), value :: size !! room in buffer, including the NUL
        type(c_handle), pointer :: handle
        character(len=:), allocatable :: text
        handle => handle_of(ptr)
        text = "not a live integrator (NULL, destroyed, or not returned by holosym_create " &
            // "or holosym_model_create)"
        if (associated(handle)) text = handle%message
        holosym_message = copy_text(text, buffer, size)
    end function holosym_message

    !> Copy `text` into a C buffer of `size` characters (NUL-terminated, truncated to
    !! size - 1 characters; nothing when the buffer is NULL); the text's full length.
    integer(c_int) function copy_text(text, buffer_ptr, size) result(length)
        character(len=*), intent(in) :: text
        type(c_ptr), intent(in) :: buffer_ptr
        integer(c_int), intent(in) :: size
        character(kind=c_char), pointer :: buffer(:)
        integer :: i, count
        length = int(len(text), c_int)
        if (size < 1 .or. .not. c_associated(buffer_ptr)) return
        call c_f_pointer(buffer_ptr, buffer, [int(size)])
        count = min(len(text), int(size) - 1)
        do i = 1, count
            buffer(i) = text(i:i)
        end do
        buffer(count + 1) = c_null_char
    end function copy_text

    !> int holosym_step(holosym_integrator *integrator, holosym_real *q, holosym_real *p,
    !! holosym_real h): one step in place; q and p unchanged on failure. Codes: those of
    !! the Fortran `step`.
    integer(c_int) function holosym_step(ptr, q_ptr, p_ptr, h) bind(C, name="holosym_step")
        type(c_ptr), value :: ptr    !! the handle
        type(c_ptr), value :: q_ptr  !! holosym_real *: coordinates (n)
        type(c_ptr), value :: p_ptr  !! holosym_real *: momenta (n)
        real(c_real), value :: h     !! step size
        type(c_handle), pointer :: handle
        type(holosym_status_t) :: status
        real(c_real), pointer :: q(:), p(:)
        real(wp), allocatable :: qw(:), pw(:)
        handle => ready_handle(ptr, "holosym_step", holosym_step)
        if (.not. associated(handle)) return
        if (.not. arrays_given(handle, "holosym_step", q_ptr, p_ptr, holosym_step)) return
        q => reals_at(q_ptr, handle%system%n)
        p => reals_at(p_ptr, handle%system%n)
        handle%record%code = 0
        qw = q
        pw = p
        call handle%integrator%step(handle%system, qw, pw, real(h, wp), status=status)
        if (status%code == HOLOSYM_SUCCESS) then
            q = qw
            p = pw
        end if
        holosym_step = finish(handle, status)
    end function holosym_step

    !> int holosym_integrate(holosym_integrator *integrator, holosym_real *q,
    !! holosym_real *p, holosym_real h, int steps, holosym_observer observer,
    !! void *observer_data, int *steps_done): `steps` steps in place, calling `observer`
    !! (may be NULL) after each; a nonzero return of the observer stops the run
    !! (HOLOSYM_USER_ABORT). Inside the observer `holosym_dense_output` evaluates the step
    !! just taken. On failure q, p hold the last good step; steps_done (may be NULL) says
    !! how many steps completed.
    integer(c_int) function holosym_integrate(ptr, q_ptr, p_ptr, h, steps, observer, &
                                              observer_data, steps_done) &
        bind(C, name="holosym_integrate")
        type(c_ptr), value :: ptr             !! the handle
        type(c_ptr), value :: q_ptr           !! holosym_real *: coordinates (n)
        type(c_ptr), value :: p_ptr           !! holosym_real *: momenta (n)
        real(c_real), value :: h              !! step size
        integer(c_int), value :: steps        !! number of steps
        type(c_funptr), value :: observer     !! observer or NULL
        type(c_ptr), value :: observer_data   !! passed to the observer
        type(c_ptr), value :: steps_done      !! int *, or NULL
        type(c_step_observer) :: bridge
        if (c_associated(observer)) call c_f_procpointer(observer, bridge%fn)
        bridge%handle = ptr
        bridge%data = observer_data
        holosym_integrate = run_integrate(ptr, "holosym_integrate", q_ptr, p_ptr, &
                                          real(h, wp), steps, bridge, steps_done)
    end function holosym_integrate

    !> The body of `holosym_integrate` and `holosym_integrate_p`: `bridge` holds the
    !! observer (fn or fn_p; neither: no observer); `caller` names the function.
    integer(c_int) function run_integrate(ptr, caller, q_ptr, p_ptr, h, steps, bridge, &
                                          steps_done) result(code)
        type(c_ptr), intent(in) :: ptr             !! the handle
        character(len=*), intent(in) :: caller     !! the C function, for messages
        type(c_ptr), intent(in) :: q_ptr           !! holosym_real *: coordinates (n)
        type(c_ptr), intent(in) :: p_ptr           !! holosym_real *: momenta (n)
        real(wp), intent(in) :: h                  !! step size
        integer(c_int), intent(in) :: steps        !! number of steps
        type(c_step_observer), intent(inout) :: bridge !! the observer, if any
        type(c_ptr), intent(in) :: steps_done      !! int *, or NULL
        type(c_handle), pointer :: handle
        type(holosym_status_t) :: status
        real(c_real), pointer :: q(:), p(:)
        real(wp), allocatable :: qw(:), pw(:)
        integer :: count
        handle => ready_handle(ptr, caller, code)
        if (.not. associated(handle)) return
        if (.not. arrays_given(handle, caller, q_ptr, p_ptr, code)) return
        q => reals_at(q_ptr, handle%system%n)
        p => reals_at(p_ptr, handle%system%n)
        handle%record%code = 0
        qw = q
        pw = p
        count = 0
        if (associated(bridge%fn) .or. associated(bridge%fn_p)) then
            call handle%integrator%integrate(handle%system, qw, pw, h, int(steps), &
                                             bridge, count, status)
        else
            call handle%integrator%integrate(handle%system, qw, pw, h, int(steps), &
                                             steps_done=count, status=status)
        end if
        if (count > 0) then
            q = qw
            p = pw
        end if
        call put_int(steps_done, count)
        code = finish(handle, status)
    end function run_integrate

    !> int holosym_integrate_events(holosym_integrator *integrator, holosym_real *q,
    !! holosym_real *p, const holosym_real *h, int steps, int count, holosym_event_fn g,
    !! const int *directions, const int *terminal, holosym_event_found_fn found,
    !! void *data, int *steps_done, int *stopped): `steps` steps in place as
    !! `holosym_integrate`, locating the zero crossings of g(k, t, q, p), k = 1..count
    !! (Fortran `integrate_events`, docs/events.md); directions (-1, 0, 1 per function)
    !! and terminal (non-zero: the run ends at the event) may be NULL (0 for all). The
    !! events are passed to `found` (may be NULL) in time order after the run, with their
    !! state and multipliers; *stopped (may be NULL) is 1 when a terminal event ended the
    !! run (q, p then hold the state at the event). Reals through pointers, so that ctypes
    !! can call it in both builds. A g that returns non-zero stops the run with
    !! HOLOSYM_NONFINITE_VALUE after the step where it did.
    integer(c_int) function holosym_integrate_events(ptr, q_ptr, p_ptr, h_ptr, steps, count, &
        g, directions, terminal, found, data, steps_done, stopped) &
        bind(C, name="holosym_integrate_events")
        type(c_ptr), value :: ptr             !! the handle
        type(c_ptr), value :: q_ptr, p_ptr    !! holosym_real *: the state (n each)
        type(c_ptr), value :: h_ptr           !! const holosym_real *: step size
        integer(c_int), value :: steps        !! number of steps
        integer(c_int), value :: count        !! number of event functions
        type(c_funptr), value :: g            !! the event functions
        type(c_ptr), value :: directions      !! const int *: count directions, or NULL
        type(c_ptr), value :: terminal        !! const int *: count flags, or NULL
        type(c_funptr), value :: found        !! receives the events, or NULL
        type(c_ptr), value :: data            !! passed to g and found
        type(c_ptr), value :: steps_done      !! int *, or NULL
        type(c_ptr), value :: stopped         !! int *, or NULL
        character(len=*), parameter :: caller = "holosym_integrate_events"
        type(c_handle), pointer :: handle
        type(c_event_set) :: events
        type(event_t), allocatable :: list(:)
        type(holosym_status_t) :: status
        real(c_real), pointer :: q(:), p(:), h
        real(wp), allocatable :: qw(:), pw(:)
        integer(c_int), pointer :: ints(:)
        integer :: done
        logical :: ended
        handle => ready_handle(ptr, caller, holosym_integrate_events)
        if (.not. associated(handle)) return
        if (.not. arrays_given(handle, caller, q_ptr, p_ptr, holosym_integrate_events)) return
        if (.not. (c_associated(h_ptr) .and. c_associated(g))) then
            holosym_integrate_events = refuse(handle, HOLOSYM_INVALID_ARGUMENT, caller // &
                ": h and g must not be NULL")
            return
        end if
        call c_f_pointer(h_ptr, h)
        call c_f_procpointer(g, events%fn)
        events%functions = max(int(count), 0)
        events%data = data
        if (c_associated(directions)) then
            call c_f_pointer(directions, ints, [events%functions])
            events%directions = ints
        end if
        if (c_associated(terminal)) then
            call c_f_pointer(terminal, ints, [events%functions])
            events%stops = ints
        end if
        q => reals_at(q_ptr, handle%system%n)
        p => reals_at(p_ptr, handle%system%n)
        handle%record%code = 0
        qw = q
        pw = p
        call integrate_events(handle%integrator, handle%system, qw, pw, real(h, wp), &
                              int(steps), events, list, ended, status, steps_done=done)
        if (done > 0 .or. ended) then
            q = qw
            p = pw
        end if
        call put_int(steps_done, done)
        call put_int(stopped, merge(1, 0, ended))
        if (c_associated(found)) call pass_events(found, list, data)
        holosym_integrate_events = finish(handle, status)
    end function holosym_integrate_events

    !> int holosym_lyapunov_spectrum(holosym_integrator *integrator, holosym_real *q,
    !! holosym_real *p, const holosym_real *h, int steps, holosym_real *exponents,
    !! holosym_real *megno, int *steps_done): the Lyapunov spectrum (2(n - m) exponents,
    !! largest first) and the mean MEGNO of the orbit from (q, p) over `steps` steps of
    !! *h (`lyapunov_spectrum`); q and p end at the state after the steps taken (also on
    !! failure, when exponents and megno cover the steps before it; untouched when none
    !! was taken). steps_done may be NULL. Reals through pointers in both builds.
    integer(c_int) function holosym_lyapunov_spectrum(ptr, q_ptr, p_ptr, h_ptr, steps, &
        exponents_ptr, megno_ptr, steps_done) bind(C, name="holosym_lyapunov_spectrum")
        type(c_ptr), value :: ptr             !! the handle
        type(c_ptr), value :: q_ptr, p_ptr    !! holosym_real *: the state (n each)
        type(c_ptr), value :: h_ptr           !! const holosym_real *: step size
        integer(c_int), value :: steps        !! number of steps
        type(c_ptr), value :: exponents_ptr   !! holosym_real *: 2(n - m) exponents
        type(c_ptr), value :: megno_ptr       !! holosym_real *: the mean MEGNO
        type(c_ptr), value :: steps_done      !! int *, or NULL
        character(len=*), parameter :: caller = "holosym_lyapunov_spectrum"
        type(c_handle), pointer :: handle
        type(lyapunov_result_t) :: result
        type(holosym_status_t) :: status
        real(c_real), pointer :: q(:), p(:), h, exponents(:), megno
        real(wp), allocatable :: qw(:), pw(:)
        handle => ready_handle(ptr, caller, holosym_lyapunov_spectrum)
        if (.not. associated(handle)) return
        if (.not. arrays_given(handle, caller, q_ptr, p_ptr, holosym_lyapunov_spectrum)) &
            return
        if (.not. (c_associated(h_ptr) .and. c_associated(exponents_ptr) .and. &
                   c_associated(megno_ptr))) then
            holosym_lyapunov_spectrum = refuse(handle, HOLOSYM_INVALID_ARGUMENT, caller // &
                ": h, exponents and megno must not be NULL")
            return
        end if
        call c_f_pointer(h_ptr, h)
        call c_f_pointer(megno_ptr, megno)
        exponents => reals_at(exponents_ptr, 2 * max(handle%system%n - handle%system%m, 0))
        q => reals_at(q_ptr, handle%system%n)
        p => reals_at(p_ptr, handle%system%n)
        handle%record%code = 0
        qw = q
        pw = p
        call lyapunov_spectrum(handle%integrator, handle%system, qw, pw, real(h, wp), &
                               int(steps), result, status)
        call put_int(steps_done, result%steps)
        if (result%steps > 0) then
            q = qw
            p = pw
            exponents = real(result%exponents, c_real)
            megno = real(result%megno, c_real)
        end if
        holosym_lyapunov_spectrum = finish(handle, status)
    end function holosym_lyapunov_spectrum

    !> int holosym_step_tangent(holosym_integrator *integrator, holosym_real *q,
    !! holosym_real *p, const holosym_real *h, int k, holosym_real *dq, holosym_real *dp):
    !! one step of *h in place and the derivative of the step map applied to k tangent
    !! vectors at the start state (the Fortran `step_tangent`): vector j (0-based) is
    !! (dq[j n .. j n + n - 1], dp[j n .. j n + n - 1]) and becomes its image at the end
    !! state. Codes: those of `step_tangent` (HOLOSYM_OFF_MANIFOLD for a vector off the
    !! tangent space: `holosym_project_tangent` projects it), HOLOSYM_INVALID_ARGUMENT for
    !! a NULL pointer or k < 1; q, p, dq and dp unchanged on failure.
    integer(c_int) function holosym_step_tangent(ptr, q_ptr, p_ptr, h_ptr, k, dq_ptr, &
        dp_ptr) bind(C, name="holosym_step_tangent")
        type(c_ptr), value :: ptr             !! the handle
        type(c_ptr), value :: q_ptr, p_ptr    !! holosym_real *: the state (n each)
        type(c_ptr), value :: h_ptr           !! const holosym_real *: step size
        integer(c_int), value :: k            !! number of tangent vectors
        type(c_ptr), value :: dq_ptr, dp_ptr  !! holosym_real *: the vectors (n k each)
        character(len=*), parameter :: caller = "holosym_step_tangent"
        type(c_handle), pointer :: handle
        type(holosym_status_t) :: status
        real(c_real), pointer :: q(:), p(:), h, dq(:, :), dp(:, :)
        real(wp), allocatable :: qw(:), pw(:), dqw(:, :), dpw(:, :)
        handle => ready_handle(ptr, caller, holosym_step_tangent)
        if (.not. associated(handle)) return
        if (.not. arrays_given(handle, caller, q_ptr, p_ptr, holosym_step_tangent)) return
        holosym_step_tangent = vectors_given(handle, caller, dq_ptr, dp_ptr, k)
        if (holosym_step_tangent /= HOLOSYM_SUCCESS) return
        if (.not. c_associated(h_ptr)) then
            holosym_step_tangent = refuse(handle, HOLOSYM_INVALID_ARGUMENT, caller // &
                ": h is NULL")
            return
        end if
        call c_f_pointer(h_ptr, h)
        q => reals_at(q_ptr, handle%system%n)
        p => reals_at(p_ptr, handle%system%n)
        dq => vectors_at(dq_ptr, handle%system%n, int(k))
        dp => vectors_at(dp_ptr, handle%system%n, int(k))
        handle%record%code = 0
        qw = q
        pw = p
        dqw = dq
        dpw = dp
        call handle%integrator%step_tangent(handle%system, qw, pw, real(h, wp), dqw, dpw, &
                                            status=status)
        if (status%code == HOLOSYM_SUCCESS) then
            q = qw
            p = pw
            dq = dqw
            dp = dpw
        end if
        holosym_step_tangent = finish(handle, status)
    end function holosym_step_tangent

    !> int holosym_tangent_basis(holosym_integrator *integrator, const holosym_real *q,
    !! const holosym_real *p, holosym_real *dq, holosym_real *dp, int *count): an
    !! orthonormal basis of the tangent space of the constraint manifold at (q, p) (the
    !! Fortran `tangent_basis`): its dimension 2(n - m) into *count (may be NULL), vector j
    !! into (dq[j n ..], dp[j n ..]); dq and dp hold n 2(n - m) reals each. Codes: those of
    !! `tangent_basis`, HOLOSYM_INVALID_ARGUMENT for a NULL pointer; outputs unchanged on
    !! failure.
    integer(c_int) function holosym_tangent_basis(ptr, q_ptr, p_ptr, dq_ptr, dp_ptr, &
        count_ptr) bind(C, name="holosym_tangent_basis")
        type(c_ptr), value :: ptr             !! the handle
        type(c_ptr), value :: q_ptr, p_ptr    !! const holosym_real *: the state (n each)
        type(c_ptr), value :: dq_ptr, dp_ptr  !! holosym_real *: the basis (n 2(n - m) each)
        type(c_ptr), value :: count_ptr       !! int *, or NULL
        character(len=*), parameter :: caller = "holosym_tangent_basis"
        type(c_handle), pointer :: handle
        type(holosym_status_t) :: status
        real(c_real), pointer :: q(:), p(:), dq(:, :), dp(:, :)
        real(wp), allocatable :: dqw(:, :), dpw(:, :)
        integer :: n, dimension, count
        handle => ready_handle(ptr, caller, holosym_tangent_basis)
        if (.not. associated(handle)) return
        if (.not. arrays_given(handle, caller, q_ptr, p_ptr, holosym_tangent_basis)) return
        n = handle%system%n
        dimension = 2 * max(n - handle%system%m, 0)
        holosym_tangent_basis = vectors_given(handle, caller, dq_ptr, dp_ptr, &
                                              int(max(dimension, 1), c_int))
        if (holosym_tangent_basis /= HOLOSYM_SUCCESS) return
        q => reals_at(q_ptr, n)
        p => reals_at(p_ptr, n)
        dq => vectors_at(dq_ptr, n, dimension)
        dp => vectors_at(dp_ptr, n, dimension)
        handle%record%code = 0
        allocate (dqw(n, dimension), dpw(n, dimension))
        call tangent_basis(handle%system, real(q, wp), real(p, wp), dqw, dpw, count, status)
        if (status%code == HOLOSYM_SUCCESS) then
            dq = dqw
            dp = dpw
            call put_int(count_ptr, count)
        end if
        holosym_tangent_basis = finish(handle, status)
    end function holosym_tangent_basis

    !> int holosym_project_tangent(holosym_integrator *integrator, const holosym_real *q,
    !! const holosym_real *p, int k, holosym_real *dq, holosym_real *dp): project the k
    !! vectors (dq[j n ..], dp[j n ..]) orthogonally onto the tangent space at (q, p) in
    !! place (the Fortran `project_tangent`). Codes: those of `project_tangent`,
    !! HOLOSYM_INVALID_ARGUMENT for a NULL pointer or k < 1; unchanged on failure.
    integer(c_int) function holosym_project_tangent(ptr, q_ptr, p_ptr, k, dq_ptr, dp_ptr) &
        bind(C, name="holosym_project_tangent")
        type(c_ptr), value :: ptr             !! the handle
        type(c_ptr), value :: q_ptr, p_ptr    !! const holosym_real *: the state (n each)
        integer(c_int), value :: k            !! number of vectors
        type(c_ptr), value :: dq_ptr, dp_ptr  !! holosym_real *: the vectors (n k each)
        character(len=*), parameter :: caller = "holosym_project_tangent"
        type(c_handle), pointer :: handle
        type(holosym_status_t) :: status
        real(c_real), pointer :: q(:), p(:), dq(:, :), dp(:, :)
        real(wp), allocatable :: dqw(:, :), dpw(:, :)
        handle => ready_handle(ptr, caller, holosym_project_tangent)
        if (.not. associated(handle)) return
        if (.not. arrays_given(handle, caller, q_ptr, p_ptr, holosym_project_tangent)) return
        holosym_project_tangent = vectors_given(handle, caller, dq_ptr, dp_ptr, k)
        if (holosym_project_tangent /= HOLOSYM_SUCCESS) return
        q => reals_at(q_ptr, handle%system%n)
        p => reals_at(p_ptr, handle%system%n)
        dq => vectors_at(dq_ptr, handle%system%n, int(k))
        dp => vectors_at(dp_ptr, handle%system%n, int(k))
        handle%record%code = 0
        dqw = dq
        dpw = dp
        call project_tangent(handle%system, real(q, wp), real(p, wp), dqw, dpw, status)
        if (status%code == HOLOSYM_SUCCESS) then
            dq = dqw
            dp = dpw
        end if
        holosym_project_tangent = finish(handle, status)
    end function holosym_project_tangent

    !> HOLOSYM_SUCCESS when the tangent vectors' pointers are not NULL and k >= 1, else
    !! the call is refused with HOLOSYM_INVALID_ARGUMENT.
    integer(c_int) function vectors_given(handle, caller, dq_ptr, dp_ptr, k) result(code)
        type(c_handle), intent(inout) :: handle
        character(len=*), intent(in) :: caller
        type(c_ptr), intent(in) :: dq_ptr, dp_ptr
        integer(c_int), intent(in) :: k
        code = int(HOLOSYM_SUCCESS, c_int)
        if (k < 1) then
            code = refuse(handle, HOLOSYM_INVALID_ARGUMENT, caller // ": k = " // &
                          decimal(int(k)) // ", at least one vector is needed")
        else if (.not. (c_associated(dq_ptr) .and. c_associated(dp_ptr))) then
            code = refuse(handle, HOLOSYM_INVALID_ARGUMENT, caller // ": dq and dp must " // &
                          "not be NULL")
        end if
    end function vectors_given

    !> Each event of `list` to the C callback `found`, in order, until it returns non-zero.
    subroutine pass_events(found, list, data)
        type(c_funptr), intent(in) :: found
        type(event_t), intent(in) :: list(:)
        type(c_ptr), intent(in) :: data
        procedure(c_event_found), pointer :: receive
        real(c_real), allocatable :: q(:), p(:), lambda(:)
        real(c_real) :: t
        integer :: j
        call c_f_procpointer(found, receive)
        do j = 1, size(list)
            t = list(j)%t
            q = list(j)%q
            p = list(j)%p
            lambda = list(j)%lambda
            if (size(lambda) == 0) lambda = [0.0_c_real]
            if (receive(int(list(j)%index, c_int), int(list(j)%direction, c_int), t, q, p, &
                        lambda, data) /= 0) exit
        end do
    end subroutine pass_events

    !> int holosym_dense_output(const holosym_integrator *integrator, holosym_real tau,
    !! holosym_real *q, holosym_real *p, holosym_real *lambda): the last step's q~, p~ and
    !! lambda~ at tau in [0, 1]; lambda may be NULL when m = 0. Codes: those of the Fortran
    !! `dense_output`, HOLOSYM_INVALID_ARGUMENT for a NULL q, p or (m > 0) lambda; outputs
    !! unchanged on failure.
    integer(c_int) function holosym_dense_output(ptr, tau, q_ptr, p_ptr, lambda_ptr) &
        bind(C, name="holosym_dense_output")
        type(c_ptr), value :: ptr         !! the handle
        real(c_real), value :: tau        !! normalised time in the last step
        type(c_ptr), value :: q_ptr       !! holosym_real *: q~(tau) (n)
        type(c_ptr), value :: p_ptr       !! holosym_real *: p~(tau) (n)
        type(c_ptr), value :: lambda_ptr  !! holosym_real *: lambda~(tau) (m), NULL if m = 0
        type(c_handle), pointer :: handle
        type(holosym_status_t) :: status
        real(c_real), pointer :: q(:), p(:), lambda(:)
        real(wp), allocatable :: qw(:), pw(:), lw(:)
        handle => ready_handle(ptr, "holosym_dense_output", holosym_dense_output)
        if (.not. associated(handle)) return
        if (.not. arrays_given(handle, "holosym_dense_output", q_ptr, p_ptr, &
                               holosym_dense_output)) return
        if (handle%system%m > 0 .and. .not. c_associated(lambda_ptr)) then
            holosym_dense_output = refuse(handle, HOLOSYM_INVALID_ARGUMENT, &
                "holosym_dense_output: lambda is NULL (m > 0)")
            return
        end if
        allocate (qw(handle%system%n), pw(handle%system%n), lw(handle%system%m))
        call handle%integrator%dense_output(real(tau, wp), qw, pw, lw, status)
        if (status%code == HOLOSYM_SUCCESS) then
            q => reals_at(q_ptr, handle%system%n)
            p => reals_at(p_ptr, handle%system%n)
            q = qw
            p = pw
            if (handle%system%m > 0) then
                lambda => reals_at(lambda_ptr, handle%system%m)
                lambda = lw
            end if
        end if
        holosym_dense_output = finish(handle, status)
    end function holosym_dense_output

    !> int holosym_project(holosym_integrator *integrator, holosym_real *q,
    !! holosym_real *p): project (q, p) onto the constraint manifold in place (the Fortran
    !! `project_to_manifold` with its defaults); unchanged on failure.
    integer(c_int) function holosym_project(ptr, q_ptr, p_ptr) bind(C, name="holosym_project")
        type(c_ptr), value :: ptr    !! the handle
        type(c_ptr), value :: q_ptr  !! holosym_real *: coordinates (n)
        type(c_ptr), value :: p_ptr  !! holosym_real *: momenta (n)
        type(c_handle), pointer :: handle
        type(holosym_status_t) :: status
        real(c_real), pointer :: q(:), p(:)
        real(wp), allocatable :: qw(:), pw(:)
        handle => ready_handle(ptr, "holosym_project", holosym_project)
        if (.not. associated(handle)) return
        if (.not. arrays_given(handle, "holosym_project", q_ptr, p_ptr, holosym_project)) return
        q => reals_at(q_ptr, handle%system%n)
        p => reals_at(p_ptr, handle%system%n)
        handle%record%code = 0
        qw = q
        pw = p
        call project_to_manifold(handle%system, qw, pw, status)
        if (status%code == HOLOSYM_SUCCESS) then
            q = qw
            p = pw
        end if
        holosym_project = finish(handle, status)
    end function holosym_project

    ! ---------------------------------------------------------------- models

    !> The NUL-terminated C string at `ptr`.
    function c_string(ptr) result(text)
        type(c_ptr), intent(in) :: ptr
        character(len=:), allocatable :: text
        character(kind=c_char), pointer :: chars(:)
        integer :: length, i
        length = int(c_strlen(ptr))
        call c_f_pointer(ptr, chars, [length])
        allocate (character(len=length) :: text)
        do i = 1, length
            text(i:i) = chars(i)
        end do
    end function c_string

    !> The handle's model, or null (with the handle's status set) when the handle holds
    !! none: `caller` names the function in the message.
    function model_of(ptr, caller, code) result(model)
        type(c_ptr), intent(in) :: ptr
        character(len=*), intent(in) :: caller
        integer(c_int), intent(out) :: code
        type(formula_model), pointer :: model
        type(c_handle), pointer :: handle
        model => null()
        code = int(HOLOSYM_NOT_INITIALIZED, c_int)
        handle => handle_of(ptr)
        if (.not. associated(handle)) return
        if (.not. allocated(handle%system)) then
            code = refuse(handle, HOLOSYM_NOT_INITIALIZED, caller // ": the model was " // &
                "not created successfully")
            return
        end if
        select type (sys => handle%system)
        type is (formula_model)
            model => sys
            code = int(HOLOSYM_SUCCESS, c_int)
        class default
            code = refuse(handle, HOLOSYM_INVALID_ARGUMENT, caller // ": the integrator " // &
                "was made by holosym_create, not from a model")
        end select
    end function model_of

    !> holosym_integrator *holosym_model_create(const char *model, int M, int N, int G):
    !! a handle for the system a model text states (the grammar of model files, lines
    !! separated by '\n') and the scheme (M, N, G). NULL only for a NULL text; otherwise
    !! check `holosym_status`: HOLOSYM_INVALID_MODEL with "model:LINE:COLUMN: ..." for a
    !! text refused, and the codes of `holosym_create`.
    function holosym_model_create(text_ptr, order_m, order_n, gauss_points) result(ptr) &
        bind(C, name="holosym_model_create")
        type(c_ptr), value :: text_ptr         !! const char *: the model, NUL-terminated
        integer(c_int), value :: order_m       !! M >= 1
        integer(c_int), value :: order_n       !! N >= 0
        integer(c_int), value :: gauss_points  !! G >= N + 1
        type(c_ptr) :: ptr
        type(c_handle), pointer :: handle
        type(formula_model) :: model
        type(holosym_status_t) :: status
        integer(c_int) :: ignored
        ptr = c_null_ptr
        if (.not. c_associated(text_ptr)) return
        ptr = new_handle(handle)
        call model_from_text(c_string(text_ptr), model, status)
        if (status%code /= HOLOSYM_SUCCESS) then
            ignored = finish(handle, status)
            return
        end if
        allocate (handle%system, source=model)
        call init_integrator(handle, order_m, order_n, gauss_points)
    end function holosym_model_create

    !> int holosym_sizes(const holosym_integrator *integrator, int *n, int *m): the
    !! system's numbers of coordinates and constraints (either pointer may be NULL).
    integer(c_int) function holosym_sizes(ptr, n_ptr, m_ptr) bind(C, name="holosym_sizes")
        type(c_ptr), value :: ptr    !! the handle
        type(c_ptr), value :: n_ptr  !! int *: n, or NULL
        type(c_ptr), value :: m_ptr  !! int *: m, or NULL
        type(c_handle), pointer :: handle
        integer(c_int), pointer :: value
        handle => handle_of(ptr)
        holosym_sizes = int(HOLOSYM_NOT_INITIALIZED, c_int)
        if (.not. associated(handle)) return
        if (.not. allocated(handle%system)) then
            holosym_sizes = refuse(handle, HOLOSYM_NOT_INITIALIZED, "holosym_sizes: the " // &
                "integrator was not created successfully")
            return
        end if
        if (c_associated(n_ptr)) then
            call c_f_pointer(n_ptr, value)
            value = int(handle%system%n, c_int)
        end if
        if (c_associated(m_ptr)) then
            call c_f_pointer(m_ptr, value)
            value = int(handle%system%m, c_int)
        end if
        holosym_sizes = refuse(handle, HOLOSYM_SUCCESS, "")
    end function holosym_sizes

    !> int holosym_model_set_parameter(holosym_integrator *integrator, const char *name,
    !! holosym_real value): set a parameter of the model by name; the integrator is set up
    !! again (the masses may change). Codes: HOLOSYM_INVALID_ARGUMENT (no such parameter,
    !! value not finite, a parameter defined from it cannot be computed, NULL name, or a
    !! handle not made from a model: the model is then unchanged), and those of the
    !! integrator's set-up.
    integer(c_int) function holosym_model_set_parameter(ptr, name_ptr, value) &
        bind(C, name="holosym_model_set_parameter")
        type(c_ptr), value :: ptr        !! the handle
        type(c_ptr), value :: name_ptr   !! const char *: the parameter's name
        real(c_real), value :: value     !! its new value
        type(formula_model), pointer :: model
        type(c_handle), pointer :: handle
        type(holosym_status_t) :: status
        model => model_of(ptr, "holosym_model_set_parameter", holosym_model_set_parameter)
        if (.not. associated(model)) return
        handle => handle_of(ptr)
        if (.not. c_associated(name_ptr)) then
            holosym_model_set_parameter = refuse(handle, HOLOSYM_INVALID_ARGUMENT, &
                "holosym_model_set_parameter: the name is NULL")
            return
        end if
        call model%set_parameter(c_string(name_ptr), real(value, wp), status)
        if (status%code /= HOLOSYM_SUCCESS) then
            holosym_model_set_parameter = finish(handle, status)
            return
        end if
        call init_integrator(handle, handle%orders(1), handle%orders(2), handle%orders(3))
        holosym_model_set_parameter = int(handle%code, c_int)
    end function holosym_model_set_parameter

    !> int holosym_model_get_parameter(holosym_integrator *integrator, const char *name,
    !! holosym_real *value): the value of a parameter of the model. Codes:
    !! HOLOSYM_INVALID_ARGUMENT (no such parameter, NULL name or value, not a model).
    integer(c_int) function holosym_model_get_parameter(ptr, name_ptr, value) &
        bind(C, name="holosym_model_get_parameter")
        type(c_ptr), value :: ptr        !! the handle
        type(c_ptr), value :: name_ptr   !! const char *: the parameter's name
        type(c_ptr), value :: value      !! holosym_real *: its value
        type(formula_model), pointer :: model
        type(c_handle), pointer :: handle
        type(holosym_status_t) :: status
        real(c_real), pointer :: out
        real(wp) :: x
        model => model_of(ptr, "holosym_model_get_parameter", holosym_model_get_parameter)
        if (.not. associated(model)) return
        handle => handle_of(ptr)
        if (.not. (c_associated(name_ptr) .and. c_associated(value))) then
            holosym_model_get_parameter = refuse(handle, HOLOSYM_INVALID_ARGUMENT, &
                "holosym_model_get_parameter: the name and the value must not be NULL")
            return
        end if
        call model%get_parameter(c_string(name_ptr), x, status)
        if (status%code == HOLOSYM_SUCCESS) then
            call c_f_pointer(value, out)
            out = x
        end if
        holosym_model_get_parameter = finish(handle, status)
    end function holosym_model_get_parameter

    !> int holosym_model_initial_state(holosym_integrator *integrator, holosym_real *q,
    !! holosym_real *p): the initial state the model states, with its current parameters,
    !! velocities turned into momenta and projected onto the constraint manifold when off
    !! it (the message then says so). Codes: HOLOSYM_INVALID_ARGUMENT (the model states no
    !! initial state, or not a model), those of the projection; q, p unchanged on failure.
    integer(c_int) function holosym_model_initial_state(ptr, q_ptr, p_ptr) &
        bind(C, name="holosym_model_initial_state")
        type(c_ptr), value :: ptr    !! the handle
        type(c_ptr), value :: q_ptr  !! holosym_real *: coordinates (n)
        type(c_ptr), value :: p_ptr  !! holosym_real *: momenta (n)
        type(formula_model), pointer :: model
        type(c_handle), pointer :: handle
        type(holosym_status_t) :: status
        character(len=:), allocatable :: note
        real(c_real), pointer :: q(:), p(:)
        real(wp), allocatable :: qw(:), pw(:)
        model => model_of(ptr, "holosym_model_initial_state", holosym_model_initial_state)
        if (.not. associated(model)) return
        handle => handle_of(ptr)
        if (.not. arrays_given(handle, "holosym_model_initial_state", q_ptr, p_ptr, &
                               holosym_model_initial_state)) return
        allocate (qw(model%n), pw(model%n))
        call model%initial_state(qw, pw, status, note)
        if (status%code == HOLOSYM_SUCCESS) then
            q => reals_at(q_ptr, model%n)
            p => reals_at(p_ptr, model%n)
            q = qw
            p = pw
            status%message = note
        end if
        holosym_model_initial_state = finish(handle, status)
    end function holosym_model_initial_state

    !> int holosym_model_parameter_count(const holosym_integrator *integrator): the
    !! number of the model's parameters (or a negative status code: not a model).
    integer(c_int) function holosym_model_parameter_count(ptr) &
        bind(C, name="holosym_model_parameter_count")
        type(c_ptr), value :: ptr !! the handle
        type(formula_model), pointer :: model
        integer(c_int) :: code
        model => model_of(ptr, "holosym_model_parameter_count", code)
        holosym_model_parameter_count = code
        if (associated(model)) holosym_model_parameter_count = int(model%parameter_count(), &
                                                                   c_int)
    end function holosym_model_parameter_count

    !> int holosym_model_name(const holosym_integrator *integrator, int what, int index,
    !! char *buffer, int size): the name of parameter, coordinate or momentum `index`
    !! (from 1; `what` is HOLOSYM_NAME_PARAMETER, HOLOSYM_NAME_COORDINATE or
    !! HOLOSYM_NAME_MOMENTUM) into buffer as holosym_message does; returns its length, or a
    !! negative status code (HOLOSYM_INVALID_ARGUMENT: `what` or `index` out of range).
    integer(c_int) function holosym_model_name(ptr, what, index, buffer, size) &
        bind(C, name="holosym_model_name")
        type(c_ptr), value :: ptr                        !! the handle
        integer(c_int), value :: what                    !! HOLOSYM_NAME_*
        integer(c_int), value :: index                   !! from 1
        type(c_ptr), value :: buffer                     !! char *: the name, or NULL
        integer(c_int), value :: size                    !! room in buffer, with the NUL
        type(formula_model), pointer :: model
        type(c_handle), pointer :: handle
        character(len=:), allocatable :: text
        integer :: last
        model => model_of(ptr, "holosym_model_name", holosym_model_name)
        if (.not. associated(model)) return
        handle => handle_of(ptr)
        select case (what)
        case (name_parameter_c)
            last = model%parameter_count()
        case (name_coordinate_c, name_momentum_c)
            last = model%n
        case default
            holosym_model_name = refuse(handle, HOLOSYM_INVALID_ARGUMENT, &
                "holosym_model_name: what must be HOLOSYM_NAME_PARAMETER, " // &
                "HOLOSYM_NAME_COORDINATE or HOLOSYM_NAME_MOMENTUM")
            return
        end select
        if (index < 1 .or. index > last) then
            holosym_model_name = refuse(handle, HOLOSYM_INVALID_ARGUMENT, &
                "holosym_model_name: index " // decimal(int(index)) // " is not in 1.." // &
                decimal(last))
            return
        end if
        select case (what)
        case (name_parameter_c)
            text = model%parameter_name(int(index))
        case (name_coordinate_c)
            text = model%coordinate_name(int(index))
        case default
            text = model%momentum_name(int(index))
        end select
        holosym_model_name = refuse(handle, HOLOSYM_SUCCESS, "")
        holosym_model_name = copy_text(text, buffer, size)
    end function holosym_model_name

    ! ---------------------------------------------------------------- reals through pointers

    !> The real at `value_ptr` (true), or false with the call refused: a NULL `value_ptr`
    !! is HOLOSYM_INVALID_ARGUMENT naming `caller` and `what`, a handle that is not live
    !! HOLOSYM_NOT_INITIALIZED (`code`).
    logical function scalar_given(ptr, caller, value_ptr, what, value, code) result(given)
        type(c_ptr), intent(in) :: ptr           !! the handle
        character(len=*), intent(in) :: caller   !! the C function
        type(c_ptr), intent(in) :: value_ptr     !! const holosym_real *
        character(len=*), intent(in) :: what     !! the argument's name
        real(c_real), intent(out) :: value       !! the real it points to
        integer(c_int), intent(out) :: code      !! the call's code when not given
        type(c_handle), pointer :: handle
        real(c_real), pointer :: target_value
        given = .false.
        value = 0
        handle => handle_of(ptr)
        code = int(HOLOSYM_NOT_INITIALIZED, c_int)
        if (.not. associated(handle)) return
        if (.not. c_associated(value_ptr)) then
            code = refuse(handle, HOLOSYM_INVALID_ARGUMENT, caller // ": " // what // &
                " is NULL")
            return
        end if
        call c_f_pointer(value_ptr, target_value)
        value = target_value
        code = int(HOLOSYM_SUCCESS, c_int)
        given = .true.
    end function scalar_given

    !> int holosym_step_p(holosym_integrator *integrator, holosym_real *q, holosym_real *p,
    !! const holosym_real *h): `holosym_step` with h through a pointer (NULL h:
    !! HOLOSYM_INVALID_ARGUMENT); otherwise its codes and messages.
    integer(c_int) function holosym_step_p(ptr, q_ptr, p_ptr, h_ptr) &
        bind(C, name="holosym_step_p")
        type(c_ptr), value :: ptr    !! the handle
        type(c_ptr), value :: q_ptr  !! holosym_real *: coordinates (n)
        type(c_ptr), value :: p_ptr  !! holosym_real *: momenta (n)
        type(c_ptr), value :: h_ptr  !! const holosym_real *: step size
        real(c_real) :: h
        if (.not. scalar_given(ptr, "holosym_step_p", h_ptr, "h", h, holosym_step_p)) return
        holosym_step_p = holosym_step(ptr, q_ptr, p_ptr, h)
    end function holosym_step_p

    !> int holosym_integrate_p(holosym_integrator *integrator, holosym_real *q,
    !! holosym_real *p, const holosym_real *h, int steps, holosym_observer_p_fn observer,
    !! void *observer_data, int *steps_done): `holosym_integrate` with h through a pointer
    !! and an observer that receives t through a pointer (NULL h: HOLOSYM_INVALID_ARGUMENT).
    integer(c_int) function holosym_integrate_p(ptr, q_ptr, p_ptr, h_ptr, steps, observer, &
                                                observer_data, steps_done) &
        bind(C, name="holosym_integrate_p")
        type(c_ptr), value :: ptr             !! the handle
        type(c_ptr), value :: q_ptr           !! holosym_real *: coordinates (n)
        type(c_ptr), value :: p_ptr           !! holosym_real *: momenta (n)
        type(c_ptr), value :: h_ptr           !! const holosym_real *: step size
        integer(c_int), value :: steps        !! number of steps
        type(c_funptr), value :: observer     !! observer (t through a pointer) or NULL
        type(c_ptr), value :: observer_data   !! passed to the observer
        type(c_ptr), value :: steps_done      !! int *, or NULL
        type(c_step_observer) :: bridge
        real(c_real) :: h
        if (.not. scalar_given(ptr, "holosym_integrate_p", h_ptr, "h", h, &
                               holosym_integrate_p)) return
        if (c_associated(observer)) call c_f_procpointer(observer, bridge%fn_p)
        bridge%handle = ptr
        bridge%data = observer_data
        holosym_integrate_p = run_integrate(ptr, "holosym_integrate_p", q_ptr, p_ptr, &
                                            real(h, wp), steps, bridge, steps_done)
    end function holosym_integrate_p

    !> int holosym_dense_output_p(const holosym_integrator *integrator,
    !! const holosym_real *tau, holosym_real *q, holosym_real *p, holosym_real *lambda):
    !! `holosym_dense_output` with tau through a pointer (NULL tau:
    !! HOLOSYM_INVALID_ARGUMENT).
    integer(c_int) function holosym_dense_output_p(ptr, tau_ptr, q_ptr, p_ptr, lambda_ptr) &
        bind(C, name="holosym_dense_output_p")
        type(c_ptr), value :: ptr         !! the handle
        type(c_ptr), value :: tau_ptr     !! const holosym_real *: tau in [0, 1]
        type(c_ptr), value :: q_ptr       !! holosym_real *: q~(tau) (n)
        type(c_ptr), value :: p_ptr       !! holosym_real *: p~(tau) (n)
        type(c_ptr), value :: lambda_ptr  !! holosym_real *: lambda~(tau) (m), NULL if m = 0
        real(c_real) :: tau
        if (.not. scalar_given(ptr, "holosym_dense_output_p", tau_ptr, "tau", tau, &
                               holosym_dense_output_p)) return
        holosym_dense_output_p = holosym_dense_output(ptr, tau, q_ptr, p_ptr, lambda_ptr)
    end function holosym_dense_output_p

    !> int holosym_model_set_parameter_p(holosym_integrator *integrator, const char *name,
    !! const holosym_real *value): `holosym_model_set_parameter` with the value through a
    !! pointer (NULL value: HOLOSYM_INVALID_ARGUMENT).
    integer(c_int) function holosym_model_set_parameter_p(ptr, name_ptr, value_ptr) &
        bind(C, name="holosym_model_set_parameter_p")
        type(c_ptr), value :: ptr        !! the handle
        type(c_ptr), value :: name_ptr   !! const char *: the parameter's name
        type(c_ptr), value :: value_ptr  !! const holosym_real *: its new value
        real(c_real) :: value
        if (.not. scalar_given(ptr, "holosym_model_set_parameter_p", value_ptr, "value", &
                               value, holosym_model_set_parameter_p)) return
        holosym_model_set_parameter_p = holosym_model_set_parameter(ptr, name_ptr, value)
    end function holosym_model_set_parameter_p

    ! ---------------------------------------------------------------- H and phi at a state

    !> int holosym_energy(holosym_integrator *integrator, const holosym_real *q,
    !! const holosym_real *p, holosym_real *energy): H(q, p) of the handle's system into
    !! *energy. Codes: HOLOSYM_INVALID_ARGUMENT (a NULL pointer), HOLOSYM_NONFINITE_VALUE
    !! (H is not finite: *energy unchanged), HOLOSYM_OUTSIDE_DOMAIN (its callback failed:
    !! *energy unchanged).
    integer(c_int) function holosym_energy(ptr, q_ptr, p_ptr, energy_ptr) &
        bind(C, name="holosym_energy")
        type(c_ptr), value :: ptr         !! the handle
        type(c_ptr), value :: q_ptr       !! const holosym_real *: coordinates (n)
        type(c_ptr), value :: p_ptr       !! const holosym_real *: momenta (n)
        type(c_ptr), value :: energy_ptr  !! holosym_real *: H(q, p)
        type(c_handle), pointer :: handle
        type(holosym_status_t) :: status
        real(c_real), pointer :: q(:), p(:), out
        real(wp) :: energy
        handle => ready_handle(ptr, "holosym_energy", holosym_energy)
        if (.not. associated(handle)) return
        if (.not. arrays_given(handle, "holosym_energy", q_ptr, p_ptr, holosym_energy)) return
        if (.not. c_associated(energy_ptr)) then
            holosym_energy = refuse(handle, HOLOSYM_INVALID_ARGUMENT, &
                "holosym_energy: energy is NULL")
            return
        end if
        q => reals_at(q_ptr, handle%system%n)
        p => reals_at(p_ptr, handle%system%n)
        handle%record%code = 0
        call clear_refusal()
        energy = handle%system%hamiltonian(real(q, wp), real(p, wp))
        call check_refusal(status, "holosym_energy")
        if (.not. status%ok()) then
            continue
        else if (ieee_is_finite(energy)) then
            call c_f_pointer(energy_ptr, out)
            out = real(energy, c_real)
        else
            status%code = HOLOSYM_NONFINITE_VALUE
            status%message = "holosym_energy: H(q, p) is not finite"
        end if
        holosym_energy = finish(handle, status)
    end function holosym_energy

    !> int holosym_plan_accuracy(holosym_integrator *integrator, const holosym_real *q,
    !! const holosym_real *p, const holosym_real *tolerance, const holosym_real *T,
    !! holosym_real *h, int *steps, int *orders): set the integrator up for an error
    !! *tolerance at *T from (q, p) (`init_for_accuracy`: the scheme, the step and the
    !! Newton tolerance from a pilot); then `holosym_integrate(integrator, q, p, *h,
    !! *steps, ...)`; orders[0..2] = (M, N, G) chosen (orders may be NULL). Codes: those of
    !! `init_for_accuracy` (HOLOSYM_INVALID_ARGUMENT also for a NULL pointer); on failure
    !! the integrator keeps its set-up and the outputs are unchanged.
    integer(c_int) function holosym_plan_accuracy(ptr, q_ptr, p_ptr, tolerance_ptr, t_ptr, &
                                                  h_ptr, steps_ptr, orders_ptr) &
        bind(C, name="holosym_plan_accuracy")
        type(c_ptr), value :: ptr            !! the handle
        type(c_ptr), value :: q_ptr, p_ptr   !! const holosym_real *: the start (n each)
        type(c_ptr), value :: tolerance_ptr  !! const holosym_real *: the error wanted at T
        type(c_ptr), value :: t_ptr          !! const holosym_real *: T
        type(c_ptr), value :: h_ptr          !! holosym_real *: the step chosen
        type(c_ptr), value :: steps_ptr      !! int *: the steps to T
        type(c_ptr), value :: orders_ptr     !! int *: (M, N, G) chosen, or NULL
        type(c_handle), pointer :: handle
        type(accuracy_plan_t) :: plan
        type(holosym_status_t) :: status
        real(c_real), pointer :: q(:), p(:), tolerance, span, h
        integer(c_int), pointer :: steps, orders(:)
        handle => ready_handle(ptr, "holosym_plan_accuracy", holosym_plan_accuracy)
        if (.not. associated(handle)) return
        if (.not. arrays_given(handle, "holosym_plan_accuracy", q_ptr, p_ptr, &
                               holosym_plan_accuracy)) return
        if (.not. (c_associated(tolerance_ptr) .and. c_associated(t_ptr) .and. &
                   c_associated(h_ptr) .and. c_associated(steps_ptr))) then
            holosym_plan_accuracy = refuse(handle, HOLOSYM_INVALID_ARGUMENT, &
                "holosym_plan_accuracy: tolerance, T, h or steps is NULL")
            return
        end if
        q => reals_at(q_ptr, handle%system%n)
        p => reals_at(p_ptr, handle%system%n)
        call c_f_pointer(tolerance_ptr, tolerance)
        call c_f_pointer(t_ptr, span)
        handle%record%code = 0
        ! The handle's integrator changes only when the plan succeeds.
        call init_for_accuracy(handle%integrator, handle%system, real(q, wp), real(p, wp), &
                               real(tolerance, wp), real(span, wp), plan, status)
        if (status%ok()) then
            handle%orders = int([plan%order_m, plan%order_n, plan%gauss_points], c_int)
            call c_f_pointer(h_ptr, h)
            call c_f_pointer(steps_ptr, steps)
            h = real(plan%h, c_real)
            steps = int(plan%steps, c_int)
            if (c_associated(orders_ptr)) then
                call c_f_pointer(orders_ptr, orders, [3])
                orders = handle%orders
            end if
        else
            status%message = "holosym_plan_accuracy: " // status%message
        end if
        holosym_plan_accuracy = finish(handle, status)
    end function holosym_plan_accuracy

    !> int holosym_constraint(holosym_integrator *integrator, const holosym_real *q,
    !! holosym_real *phi): the constraint values phi(q) (m of them; phi may be NULL when
    !! m = 0). Codes: HOLOSYM_INVALID_ARGUMENT (a NULL pointer), HOLOSYM_NONFINITE_VALUE
    !! (a value not finite: phi unchanged), HOLOSYM_OUTSIDE_DOMAIN (the callback failed:
    !! phi unchanged).
    integer(c_int) function holosym_constraint(ptr, q_ptr, phi_ptr) &
        bind(C, name="holosym_constraint")
        type(c_ptr), value :: ptr      !! the handle
        type(c_ptr), value :: q_ptr    !! const holosym_real *: coordinates (n)
        type(c_ptr), value :: phi_ptr  !! holosym_real *: phi(q) (m), NULL if m = 0
        type(c_handle), pointer :: handle
        type(holosym_status_t) :: status
        real(c_real), pointer :: q(:), out(:)
        real(wp), allocatable :: phi(:)
        handle => ready_handle(ptr, "holosym_constraint", holosym_constraint)
        if (.not. associated(handle)) return
        if (.not. c_associated(q_ptr)) then
            holosym_constraint = refuse(handle, HOLOSYM_INVALID_ARGUMENT, &
                "holosym_constraint: q is NULL")
            return
        end if
        if (handle%system%m > 0 .and. .not. c_associated(phi_ptr)) then
            holosym_constraint = refuse(handle, HOLOSYM_INVALID_ARGUMENT, &
                "holosym_constraint: phi is NULL (m > 0)")
            return
        end if
        q => reals_at(q_ptr, handle%system%n)
        handle%record%code = 0
        allocate (phi(handle%system%m))
        call clear_refusal()
        call handle%system%constraint(real(q, wp), phi)
        call check_refusal(status, "holosym_constraint")
        if (.not. status%ok()) then
            continue
        else if (all(ieee_is_finite(phi))) then
            if (handle%system%m > 0) then
                out => reals_at(phi_ptr, handle%system%m)
                out = real(phi, c_real)
            end if
        else
            status%code = HOLOSYM_NONFINITE_VALUE
            status%message = "holosym_constraint: phi(q) is not finite"
        end if
        holosym_constraint = finish(handle, status)
    end function holosym_constraint

#else
    implicit none
    private
    !> False: a real128 build needs gfortran's c_float128 for the C interface.
    logical, parameter, public :: c_interface_available = .false.
#endif
end module holosym_c
