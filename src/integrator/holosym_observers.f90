!> category: internal module (use holosym)
!! The two observers that every user of `integrate` writes otherwise: a trajectory writer
!! (CSV with the columns of `holosym simulate`) and an energy and constraint monitor.
!!
!!     type(trajectory_writer) :: writer
!!     call writer%open(sys, q, p, file="run.csv", digits=17, status=status)
!!     call integ%integrate(sys, q, p, h, steps, writer, status=status)
!!     call writer%close(status)
!!     print *, writer%monitor%max_energy_error, writer%monitor%max_constraint_residual
!!
!! Columns: `t,q1..qn,p1..pn,lambda1..lambdam,H,energy_error,constraint_residual,`
!! `velocity_residual,newton_iterations`, one row for the start and one per written step:
!! - lambda: the multipliers at the end of the step (t = 0: at the start of the first step;
!!   NaN when no step was taken);
!! - energy_error: (H - H0)/H0 (H - H0 when H0 = 0);
!! - constraint_residual: max |phi| over the step's displacement nodes (t = 0: at q0);
!! - velocity_residual: max |Phi(q) dH/dp(q, p)| at the row's state;
!! - newton_iterations: of the step (0 at t = 0).
!! With `interval` > 0 the rows are at the multiples of `interval` instead, from the step's
!! dense output (`step_dense_output`) between step ends; such a row's residuals are those
!! of the interpolated state, which meets the constraints only at the displacement nodes.
!!
!! A file opened by the writer (`file=`) is written through the C library's streams
!! (`holosym_text_file`): a row that does not reach it (a full disk or device, a
!! file-size limit) stops the run and `close` reports it, which Fortran units do not
!! guarantee (gfortran 12 reports nothing, LLVM flang stops the program). With `unit=`
!! the caller's unit is written as it is.
module holosym_observers
    use, intrinsic :: iso_fortran_env, only: int64
    use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan, ieee_positive_inf
    use holosym_kinds, only: wp
    use holosym_status_codes, only: holosym_status_t, set_status, int_str, int_len, real_str, &
        is_finite, HOLOSYM_SUCCESS, HOLOSYM_SIZE_MISMATCH, HOLOSYM_INVALID_ARGUMENT, &
        HOLOSYM_INVALID_DIMENSION, HOLOSYM_NONFINITE_VALUE, HOLOSYM_NOT_INITIALIZED, &
        HOLOSYM_USER_ABORT
    use holosym_problem, only: constrained_hamiltonian
    use holosym_manifold, only: manifold_residuals
    use holosym_integrator, only: step_observer, step_info_t
    use holosym_text_file, only: text_file_t
    implicit none
    private

    public :: trajectory_writer, energy_monitor, trajectory_header

    !> The columns after the state in `trajectory_header`.
    character(len=*), parameter :: header_tail = ",H,energy_error,constraint_residual," // &
        "velocity_residual,newton_iterations"

    !> Significant digits of the writer: 17 (exact for real64) or 36 (exact for real128).
    integer, parameter :: short_digits = 17, long_digits = 36

    !> Records, over a run of `integrate`, the largest energy error and constraint residuals
    !! and the Newton iterations. Call `start` with the start state first.
    type, extends(step_observer) :: energy_monitor
        !> H0 = H(q0, p0).
        real(wp) :: initial_energy = 0
        !> max |(H - H0)/H0| over the steps (max |H - H0| when H0 = 0).
        real(wp) :: max_energy_error = 0
        !> max |phi| over the start and every step's displacement nodes.
        real(wp) :: max_constraint_residual = 0
        !> max |Phi H_p| over the start and every step's end state.
        real(wp) :: max_velocity_residual = 0
        !> Steps observed.
        integer :: steps = 0
        !> Newton iterations over all steps.
        integer(int64) :: newton_iterations = 0
        !> Most Newton iterations in one step.
        integer :: max_newton_iterations = 0
        !> Why the monitor stopped a run ("" when it did not).
        character(len=:), allocatable :: message
        class(constrained_hamiltonian), allocatable, private :: sys
        real(wp), private :: energy_scale = 1
    contains
        !> Record the start state (H0 and its residuals) and clear the maxima.
        procedure :: start => monitor_start
        !> Update the maxima after a step (called by `integrate`).
        procedure :: observe => monitor_observe
        !> Update the maxima with one step's values (for observers that hold a monitor).
        procedure :: record => monitor_record
        !> Mean Newton iterations per step.
        procedure :: mean_newton_iterations => monitor_mean_iterations
    end type energy_monitor

    !> Writes a run of `integrate` as CSV (see the module's documentation for the columns)
    !! and keeps an `energy_monitor` of it. `open` it with the start state, pass it to
    !! `integrate`, then `close` it.
    type, extends(step_observer) :: trajectory_writer
        !> Maxima and iterations over every step (not only the written rows).
        type(energy_monitor) :: monitor
        !> Data rows written (the header not counted).
        integer :: rows = 0
        integer, private :: unit = -1
        logical, private :: owns_unit = .false.
        !> The file opened by `open` (when `file=` was given).
        type(text_file_t), private :: file
        logical, private :: opened = .false.
        character(len=16), private :: real_format = ""
        integer, private :: every = 1
        real(wp), private :: interval = 0
        real(wp), private :: start_time = 0
        integer(int64), private :: next_output = 1
        class(constrained_hamiltonian), allocatable, private :: sys
        real(wp), allocatable, private :: q0(:), p0(:)
        real(wp), private :: position0 = 0, velocity0 = 0
        logical, private :: initial_written = .false.
        ! The last observed step, written by `close` when its row is still missing.
        logical, private :: pending = .false.
        integer, private :: last_iterations = 0
        real(wp), private :: last_t = 0, last_position = 0, last_velocity = 0
        real(wp), allocatable, private :: last_q(:), last_p(:), last_lambda(:)
        integer, private :: io_status = 0
        character(len=:), allocatable, private :: io_message
    contains
        !> Open the CSV (a file or an open unit), write the header, record the start state.
        procedure :: open => writer_open
        !> Write the rows of a step (called by `integrate`).
        procedure :: observe => writer_observe
        !> Write the last step's row if still missing; close a file opened by `open`.
        procedure :: close => writer_close
    end type trajectory_writer

contains

    ! ---------------------------------------------------------------- energy monitor

    !> Record the start of a run: H0 and the residuals of (q, p); the maxima restart from
    !! them. Codes: HOLOSYM_INVALID_DIMENSION (n < 1, m < 0 or m >= n),
    !! HOLOSYM_SIZE_MISMATCH (q, p not of size n), HOLOSYM_INVALID_ARGUMENT (q or p not
    !! finite), HOLOSYM_NONFINITE_VALUE (H or the residuals not finite). On failure the
    !! monitor is unchanged.
    subroutine monitor_start(self, sys, q, p, status)
        class(energy_monitor), intent(inout) :: self
        class(constrained_hamiltonian), intent(in) :: sys !! the system
        real(wp), intent(in) :: q(:) !! start coordinates (n)
        real(wp), intent(in) :: p(:) !! start momenta (n)
        type(holosym_status_t), intent(out), optional :: status !! outcome
        type(holosym_status_t) :: local
        real(wp) :: energy, position, velocity
        call check_state(sys, q, p, local)
        if (local%ok()) then
            energy = sys%hamiltonian(q, p)
            call manifold_residuals(sys, q, p, position, velocity)
            if (.not. (is_finite(energy) .and. is_finite(position) .and. &
                       is_finite(velocity))) call set_status(local, HOLOSYM_NONFINITE_VALUE, &
                "H or the constraint residuals of the start state are NaN or Inf")
        end if
        if (.not. local%ok()) then
            call set_status(status, local%code, local%message)
            return
        end if
        if (allocated(self%sys)) deallocate (self%sys)
        allocate (self%sys, source=sys)
        self%initial_energy = energy
        self%energy_scale = energy
        if (.not. abs(energy) > 0) self%energy_scale = 1
        self%max_energy_error = 0
        self%max_constraint_residual = position
        self%max_velocity_residual = velocity
        self%steps = 0
        self%newton_iterations = 0
        self%max_newton_iterations = 0
        self%message = ""
        call set_status(status, HOLOSYM_SUCCESS, "")
    end subroutine monitor_start

    !> After a step: update the maxima. Before `start` it halts the run (the integrator then
    !! returns HOLOSYM_USER_ABORT) and says why in `message`.
    subroutine monitor_observe(self, step, t, q, p, info, halt)
        class(energy_monitor), intent(inout) :: self
        integer, intent(in) :: step           !! step number
        real(wp), intent(in) :: t             !! time after the step
        real(wp), intent(in) :: q(:)          !! coordinates after the step
        real(wp), intent(in) :: p(:)          !! momenta after the step
        type(step_info_t), intent(in) :: info !! diagnostics of the step
        logical, intent(inout) :: halt        !! set when the monitor was not started
        if (.not. allocated(self%sys)) then
            self%message = "energy_monitor: call start with the start state before integrate"
            halt = .true.
            return
        end if
        call self%record(self%sys%hamiltonian(q, p), info%constraint_residual, &
                                      info%velocity_residual, info%newton_iterations)
    end subroutine monitor_observe

    !> Count a step and update the maxima with its values: its energy, max |phi| over its
    !! displacement nodes, |Phi H_p| at its end and its Newton iterations. A non-finite
    !! energy makes `max_energy_error` +Inf.
    pure subroutine monitor_record(self, energy, position, velocity, iterations)
        class(energy_monitor), intent(inout) :: self
        real(wp), intent(in) :: energy     !! H after the step
        real(wp), intent(in) :: position   !! max |phi| over the step's nodes
        real(wp), intent(in) :: velocity   !! max |Phi H_p| at the step's end
        integer, intent(in) :: iterations  !! Newton iterations of the step
        self%steps = self%steps + 1
        if (is_finite(energy)) then
            self%max_energy_error = max(self%max_energy_error, &
                abs((energy - self%initial_energy) / self%energy_scale))
        else
            ! H returned NaN or Inf (a run with check_roots off, which would have stopped
            ! with HOLOSYM_NONFINITE_VALUE): the error is unbounded, found by
            ! classification (no comparison with a NaN).
            self%max_energy_error = ieee_value(self%max_energy_error, ieee_positive_inf)
        end if
        self%max_constraint_residual = max(self%max_constraint_residual, position)
        self%max_velocity_residual = max(self%max_velocity_residual, velocity)
        self%newton_iterations = self%newton_iterations + iterations
        self%max_newton_iterations = max(self%max_newton_iterations, iterations)
    end subroutine monitor_record

    !> Mean Newton iterations per observed step (0 before the first).
    pure real(wp) function monitor_mean_iterations(self) result(mean)
        class(energy_monitor), intent(in) :: self
        mean = 0
        if (self%steps > 0) mean = real(self%newton_iterations, wp) / self%steps
    end function monitor_mean_iterations

    ! ---------------------------------------------------------------- trajectory writer

    !> Length of `trajectory_header(n, m)`.
    pure integer function header_length(n, m)
        integer, intent(in) :: n !! number of coordinates
        integer, intent(in) :: m !! number of constraints
        integer :: i
        header_length = len("t") + len(header_tail)
        do i = 1, max(n, 0)
            header_length = header_length + 2 * (2 + int_len(i))
        end do
        do i = 1, max(m, 0)
            header_length = header_length + 7 + int_len(i)
        end do
    end function header_length

    !> The CSV header for n coordinates and m constraints, e.g. for n = 3, m = 1:
    !! `t,q1,q2,q3,p1,p2,p3,lambda1,H,energy_error,constraint_residual,velocity_residual,`
    !! `newton_iterations`. (A computed length, not a deferred one: see `int_str`.)
    pure function trajectory_header(n, m) result(header)
        integer, intent(in) :: n !! number of coordinates
        integer, intent(in) :: m !! number of constraints
        character(len=header_length(n, m)) :: header !! the header line
        integer :: i, k, used, name_length
        character(len=7) :: name
        header(1:1) = "t"
        used = 1
        do i = 1, 2 * max(n, 0) + max(m, 0)
            if (i <= n) then
                name = ",q"
                name_length = 2
                k = i
            else if (i <= 2 * n) then
                name = ",p"
                name_length = 2
                k = i - n
            else
                name = ",lambda"
                name_length = 7
                k = i - 2 * n
            end if
            header(used + 1:used + name_length + int_len(k)) = name(:name_length) // int_str(k)
            used = used + name_length + int_len(k)
        end do
        header(used + 1:) = header_tail
    end function trajectory_header

    !> Open the writer for a run of `sys` from (q, p): the CSV goes to `file` (replaced) or
    !! to the open formatted `unit`; the header is written at once, the start row with the
    !! first step (it holds the first step's initial multipliers) or at `close`.
    !! Codes: those of `energy_monitor%start`; HOLOSYM_INVALID_ARGUMENT for both or neither
    !! of file and unit, digits not 17 or 36, every < 1, interval not finite or < 0, a file
    !! that cannot be opened or a header that cannot be written. On failure nothing is
    !! written and the writer is left closed.
    subroutine writer_open(self, sys, q, p, file, unit, digits, every, interval, start_time, &
                           status)
        class(trajectory_writer), intent(inout) :: self
        class(constrained_hamiltonian), intent(in) :: sys !! the system
        real(wp), intent(in) :: q(:) !! start coordinates (n)
        real(wp), intent(in) :: p(:) !! start momenta (n)
        character(len=*), intent(in), optional :: file !! CSV file to write (replaced)
        integer, intent(in), optional :: unit          !! or an open formatted unit
        integer, intent(in), optional :: digits        !! 17 or 36 significant digits [36]
        integer, intent(in), optional :: every         !! a row every `every` steps [1]
        !> > 0: rows at start_time + k interval, from the dense output, instead of `every`.
        real(wp), intent(in), optional :: interval
        real(wp), intent(in), optional :: start_time   !! t of (q, p), as given to integrate [0]
        type(holosym_status_t), intent(out), optional :: status !! outcome
        type(holosym_status_t) :: local
        type(energy_monitor) :: monitor
        character(len=256) :: io_message
        type(text_file_t) :: new_file
        integer :: chosen_digits, chosen_every, new_unit, ios
        logical :: closed
        real(wp) :: chosen_interval, t0

        chosen_digits = long_digits
        if (present(digits)) chosen_digits = digits
        chosen_every = 1
        if (present(every)) chosen_every = every
        chosen_interval = 0
        if (present(interval)) chosen_interval = interval
        t0 = 0
        if (present(start_time)) t0 = start_time
        if (present(file) .eqv. present(unit)) then
            call set_status(local, HOLOSYM_INVALID_ARGUMENT, "trajectory_writer%open needs " // &
                "either file or unit")
        else if (chosen_digits /= short_digits .and. chosen_digits /= long_digits) then
            call set_status(local, HOLOSYM_INVALID_ARGUMENT, "digits must be 17 or 36; got " &
                // int_str(chosen_digits))
        else if (chosen_every < 1) then
            call set_status(local, HOLOSYM_INVALID_ARGUMENT, "every must be >= 1; got " // &
                int_str(chosen_every))
        else if (.not. (is_finite(chosen_interval) .and. chosen_interval >= 0)) then
            call set_status(local, HOLOSYM_INVALID_ARGUMENT, "interval must be >= 0 and " // &
                "finite; got " // real_str(chosen_interval))
        else if (.not. is_finite(t0)) then
            call set_status(local, HOLOSYM_INVALID_ARGUMENT, "start_time must be finite; got " &
                // real_str(t0))
        else
            call monitor%start(sys, q, p, local)
        end if
        if (local%ok()) then
            new_unit = -1
            if (present(file)) then
                if (.not. new_file%open(file, "replace")) call set_status(local, &
                    HOLOSYM_INVALID_ARGUMENT, new_file%failure)
            else
                new_unit = unit
            end if
        end if
        if (local%ok()) then
            if (present(file)) then
                call new_file%line(trajectory_header(sys%n, sys%m))
                call new_file%flush()
                if (new_file%failed()) then
                    call set_status(local, HOLOSYM_INVALID_ARGUMENT, "cannot write the " // &
                        "header: " // new_file%failure)
                    closed = new_file%close()
                end if
            else
                write (new_unit, '(a)', iostat=ios, iomsg=io_message) &
                    trajectory_header(sys%n, sys%m)
                if (ios /= 0) call set_status(local, HOLOSYM_INVALID_ARGUMENT, &
                    "cannot write the header: " // trim(io_message))
            end if
        end if
        if (.not. local%ok()) then
            call set_status(status, local%code, local%message)
            return
        end if
        if (self%opened .and. self%owns_unit) closed = self%file%close()
        self%monitor = monitor
        self%rows = 0
        self%unit = new_unit
        self%owns_unit = present(file)
        if (present(file)) self%file = new_file
        self%opened = .true.
        if (chosen_digits == short_digits) then
            self%real_format = '(es25.16e4)'
        else
            self%real_format = '(es44.35e4)'
        end if
        self%every = chosen_every
        self%interval = chosen_interval
        self%start_time = t0
        self%next_output = 1
        if (allocated(self%sys)) deallocate (self%sys)
        allocate (self%sys, source=sys)
        self%q0 = q
        self%p0 = p
        self%position0 = monitor%max_constraint_residual
        self%velocity0 = monitor%max_velocity_residual
        self%initial_written = .false.
        self%pending = .false.
        self%io_status = 0
        self%io_message = ""
        call set_status(status, HOLOSYM_SUCCESS, "")
    end subroutine writer_open

    !> After step k: the start row (at k = 1), then the row of step k when k is a multiple
    !! of `every`, or the rows at the multiples of `interval` inside the step. A write
    !! failure (or a writer not opened) halts the run; `close` then reports it.
    subroutine writer_observe(self, step, t, q, p, info, halt)
        class(trajectory_writer), intent(inout) :: self
        integer, intent(in) :: step           !! step number
        real(wp), intent(in) :: t             !! time after the step
        real(wp), intent(in) :: q(:)          !! coordinates after the step
        real(wp), intent(in) :: p(:)          !! momenta after the step
        type(step_info_t), intent(in) :: info !! diagnostics of the step
        logical, intent(inout) :: halt        !! set on a failure
        real(wp), allocatable :: qi(:), pi(:), lambda(:)
        real(wp) :: energy, tout, position, velocity
        type(holosym_status_t) :: local

        if (.not. self%opened) then
            self%io_status = -1
            self%io_message = "trajectory_writer: call open before integrate"
            halt = .true.
            return
        end if
        if (.not. self%initial_written) call write_initial(self, &
            info%lambda(:, lbound(info%lambda, 2)))
        energy = self%sys%hamiltonian(q, p)
        call self%monitor%record(energy, info%constraint_residual, &
                                              info%velocity_residual, info%newton_iterations)
        if (self%interval > 0) then
            allocate (qi(size(q)), pi(size(p)), lambda(self%sys%m))
            do
                tout = self%start_time + self%next_output * self%interval
                if (tout > t * (1 + 4 * epsilon(1.0_wp)) + tiny(1.0_wp)) exit
                if (abs(tout - t) <= 4 * epsilon(1.0_wp) * max(1.0_wp, abs(t))) then
                    ! A row at the step end holds the step's own state.
                    call write_row(self, t, q, p, info%lambda(:, ubound(info%lambda, 2)), &
                        energy, info%constraint_residual, info%velocity_residual, &
                        info%newton_iterations)
                else
                    call self%dense%evaluate(tout, qi, pi, lambda, local)
                    if (.not. local%ok()) then
                        self%io_status = -1
                        self%io_message = "dense output at t = " // real_str(tout) // ": " &
                            // local%message
                        exit
                    end if
                    call manifold_residuals(self%sys, qi, pi, position, velocity)
                    call write_row(self, tout, qi, pi, lambda, self%sys%hamiltonian(qi, pi), &
                                   position, velocity, info%newton_iterations)
                end if
                self%next_output = self%next_output + 1
                if (self%io_status /= 0) exit
            end do
            self%pending = .false.
        else if (mod(step, self%every) == 0) then
            call write_row(self, t, q, p, info%lambda(:, ubound(info%lambda, 2)), energy, &
                           info%constraint_residual, info%velocity_residual, &
                           info%newton_iterations)
            self%pending = .false.
        else
            self%pending = .true.
            self%last_t = t
            self%last_q = q
            self%last_p = p
            self%last_lambda = info%lambda(:, ubound(info%lambda, 2))
            self%last_position = info%constraint_residual
            self%last_velocity = info%velocity_residual
            self%last_iterations = info%newton_iterations
        end if
        if (self%io_status /= 0) halt = .true.
    end subroutine writer_observe

    !> Finish the CSV: the start row when no step was observed (multipliers NaN), the last
    !! observed step's row when `every` skipped it; close a file opened by `open`.
    !! Codes: HOLOSYM_NOT_INITIALIZED (not opened), HOLOSYM_USER_ABORT (a row did not
    !! reach the file: a full disk or device, a file-size limit; the message says which).
    subroutine writer_close(self, status)
        class(trajectory_writer), intent(inout) :: self
        type(holosym_status_t), intent(out), optional :: status !! outcome
        real(wp), allocatable :: nan(:)
        integer :: ios
        if (.not. self%opened) then
            call set_status(status, HOLOSYM_NOT_INITIALIZED, "trajectory_writer: close " // &
                "without open")
            return
        end if
        if (self%io_status == 0) then
            if (.not. self%initial_written) then
                allocate (nan(self%sys%m))
                nan = ieee_value(1.0_wp, ieee_quiet_nan)
                call write_initial(self, nan)
            end if
            if (self%pending .and. self%io_status == 0) call write_row(self, self%last_t, &
                self%last_q, self%last_p, self%last_lambda, &
                self%sys%hamiltonian(self%last_q, self%last_p), self%last_position, &
                self%last_velocity, self%last_iterations)
            self%pending = .false.
        end if
        if (self%owns_unit) then
            if (.not. self%file%close() .and. self%io_status == 0) then
                self%io_status = -1
                self%io_message = self%file%failure
            end if
        else
            flush (self%unit, iostat=ios)
        end if
        self%opened = .false.
        if (self%io_status /= 0) then
            call set_status(status, HOLOSYM_USER_ABORT, "writing the trajectory failed " // &
                "after " // int_str(self%rows) // " rows: " // self%io_message)
        else
            call set_status(status, HOLOSYM_SUCCESS, "")
        end if
    end subroutine writer_close

    ! ---------------------------------------------------------------- helpers

    !> The checks of a state common to both observers.
    subroutine check_state(sys, q, p, status)
        class(constrained_hamiltonian), intent(in) :: sys
        real(wp), intent(in) :: q(:), p(:)
        type(holosym_status_t), intent(inout) :: status
        if (sys%n < 1 .or. sys%m < 0 .or. sys%m >= sys%n) then
            call set_status(status, HOLOSYM_INVALID_DIMENSION, "need n >= 1 and 0 <= m < n; " &
                // "got n = " // int_str(sys%n) // ", m = " // int_str(sys%m))
        else if (size(q) /= sys%n .or. size(p) /= sys%n) then
            call set_status(status, HOLOSYM_SIZE_MISMATCH, "q and p must have size n = " // &
                int_str(sys%n) // "; got " // int_str(size(q)) // " and " // int_str(size(p)))
        else if (.not. (all(is_finite(q)) .and. all(is_finite(p)))) then
            call set_status(status, HOLOSYM_INVALID_ARGUMENT, "q or p contains NaN or Inf")
        else
            call set_status(status, HOLOSYM_SUCCESS, "")
        end if
    end subroutine check_state

    !> The start row.
    subroutine write_initial(self, lambda)
        class(trajectory_writer), intent(inout) :: self
        real(wp), intent(in) :: lambda(:)
        self%initial_written = .true.
        call write_row(self, self%start_time, self%q0, self%p0, lambda, &
                       self%monitor%initial_energy, self%position0, self%velocity0, 0, &
                       start_row=.true.)
    end subroutine write_initial

    !> One CSV row; an I/O failure is kept for `close`.
    subroutine write_row(self, t, q, p, lambda, energy, position, velocity, iterations, &
                         start_row)
        class(trajectory_writer), intent(inout) :: self
        real(wp), intent(in) :: t, q(:), p(:), lambda(:), energy, position, velocity
        integer, intent(in) :: iterations
        logical, intent(in), optional :: start_row !! the start: energy error 0 by definition
        real(wp) :: energy_error
        character(len=:), allocatable :: line
        character(len=256) :: io_message
        integer :: i, ios, used
        ! Filled in place (appending field by field copies the line once per field).
        allocate (character(len=(size(q) + size(p) + size(lambda) + 6) * 50) :: line)
        used = 0
        call put_real("", t)
        do i = 1, size(q)
            call put_real(",", q(i))
        end do
        do i = 1, size(p)
            call put_real(",", p(i))
        end do
        do i = 1, size(lambda)
            call put_real(",", lambda(i))
        end do
        energy_error = (energy - self%monitor%initial_energy) / self%monitor%energy_scale
        if (present(start_row)) energy_error = 0
        call put_real(",", energy)
        call put_real(",", energy_error)
        call put_real(",", position)
        call put_real(",", velocity)
        call put("," // int_str(iterations))
        if (self%owns_unit) then
            call self%file%line(line(:used))
            if (self%file%failed()) then
                self%io_status = -1
                self%io_message = self%file%failure
            else
                self%rows = self%rows + 1
            end if
        else
            write (self%unit, '(a)', iostat=ios, iomsg=io_message) line(:used)
            if (ios /= 0) then
                self%io_status = ios
                self%io_message = trim(io_message)
            else
                self%rows = self%rows + 1
            end if
        end if
    contains
        ! A subroutine, not a function of deferred length (see int_str): writers may run
        ! on several threads.
        subroutine put_real(separator, value)
            character(len=*), intent(in) :: separator
            real(wp), intent(in) :: value
            character(len=48) :: buffer
            write (buffer, self%real_format) value
            call put(separator // trim(adjustl(buffer)))
        end subroutine put_real
        subroutine put(text)
            character(len=*), intent(in) :: text
            line(used + 1:used + len(text)) = text
            used = used + len(text)
        end subroutine put
    end subroutine write_row

end module holosym_observers
