!> Convergence studies behind the `tables` command: measured orders of the energy error
!! and of the global error for a grid of (M, N, G), and the smallest G that gives a
!! nonsingular Newton Jacobian. Cells are independent and run in parallel with OpenMP
!! when the library is built with it, or on the ranks of a task farm (holosym-mpi).
module holosym_convergence
    use, intrinsic :: iso_fortran_env, only: error_unit
    use holosym_kinds, only: wp
    use holosym_status_codes, only: holosym_status_t, set_status, int_str, real_str, status_code_name, &
        HOLOSYM_SUCCESS, HOLOSYM_SINGULAR_MATRIX, HOLOSYM_INVALID_ARGUMENT, &
        HOLOSYM_INVALID_ORDER, HOLOSYM_STEP_TOO_LARGE
    use holosym_problem, only: constrained_hamiltonian
    use holosym_integrator, only: constrained_integrator
    use holosym_task_farm, only: farm_job, task_farm
    use holosym_records, only: record_reader_t, put
    use holosym_progress, only: progress_clock_t
    implicit none
    private

    public :: order_cell_t, study_settings_t, paper_order_law, measure_order, &
              run_order_cells, minimum_gauss_points, reference_solution

    !> Settings of a convergence study.
    type :: study_settings_t
        !> Time span [0, T] of every run.
        real(wp) :: span = 10
        !> Step sizes to try, largest first; each run uses span / h steps.
        real(wp), allocatable :: step_sizes(:)
        !> Errors at or below this are round-off dominated and not used for orders.
        real(wp) :: error_floor = 1.0e-28_wp
        !> The same for the global error, which is also limited by the reference's accuracy.
        real(wp) :: global_floor = 1.0e-28_wp
        !> Stop refining once two successive orders agree this closely.
        real(wp) :: settled = 0.1_wp
        !> Print one line per finished cell to stderr.
        logical :: progress = .true.
    end type study_settings_t

    !> One cell of an order table: a configuration and what was measured.
    type :: order_cell_t
        integer :: order_m = 0       !! M
        integer :: order_n = 0       !! N
        integer :: gauss_points = 0  !! G
        !> Status of the runs: 0, HOLOSYM_SINGULAR_MATRIX, or another failure code.
        integer :: code = HOLOSYM_SUCCESS
        !> Failure message, if any.
        character(len=:), allocatable :: message
        !> Levels computed (runs with `levels` successive step sizes, after the largest ones
        !! the integrator refused as too large).
        integer :: levels = 0
        !> Step sizes of the pair used for the energy order.
        real(wp) :: energy_h(2) = 0
        !> E = max_t |(H_t - H_0)/H_0| at those step sizes.
        real(wp) :: energy_error(2) = 0
        !> Measured order of the energy error (NaN-free: 0 when not measurable).
        real(wp) :: energy_order = 0
        !> True when an energy order could be measured above the floor.
        logical :: energy_measured = .false.
        !> Step sizes of the pair used for the global-error order.
        real(wp) :: global_h(2) = 0
        !> max |q(T) - q_ref(T)| at those step sizes.
        real(wp) :: global_error(2) = 0
        !> Measured order of the global error of q(T).
        real(wp) :: global_order = 0
        !> True when a global order could be measured above the floor.
        logical :: global_measured = .false.
        !> Wall-clock seconds of the cell.
        real(wp) :: seconds = 0
    end type order_cell_t

    !> The cells of `run_order_cells` as tasks of a farm: task i is cells(i).
    type, extends(farm_job) :: cells_job
        class(constrained_hamiltonian), allocatable :: sys
        real(wp), allocatable :: q0(:), p0(:), q_ref(:)
        type(study_settings_t) :: settings
        type(order_cell_t), allocatable :: cells(:)
        character(len=:), allocatable :: label
        integer :: finished = 0
    contains
        procedure :: run => cells_job_run
        procedure :: accept => cells_job_accept
    end type cells_job

    interface
        !> Does nothing. Its body, in the submodule at the end of this file, keeps this
        !! application module out of `fpm install` (see fpm.toml).
        module subroutine not_installed()
        end subroutine not_installed
    end interface

contains

    !> The paper's law for the energy order: min(2M, 2N) if M /= N+1, else min(2M, 2N+2).
    pure integer function paper_order_law(order_m, order_n)
        integer, intent(in) :: order_m !! M
        integer, intent(in) :: order_n !! N
        if (order_m == order_n + 1) then
            paper_order_law = min(2 * order_m, 2 * order_n + 2)
        else
            paper_order_law = min(2 * order_m, 2 * order_n)
        end if
    end function paper_order_law

    !> One run over [0, span] with step h: max relative energy error and q(span).
    subroutine run_once(sys, q0, p0, order_m, order_n, gauss_points, h, span, energy_error, &
                        q_end, status)
        class(constrained_hamiltonian), intent(in) :: sys
        real(wp), intent(in) :: q0(:), p0(:), h, span
        integer, intent(in) :: order_m, order_n, gauss_points
        real(wp), intent(out) :: energy_error
        real(wp), intent(out) :: q_end(:)
        type(holosym_status_t), intent(out) :: status
        type(constrained_integrator) :: integrator
        real(wp) :: q(size(q0)), p(size(p0)), energy0
        integer :: k

        energy_error = 0
        q = q0
        p = p0
        q_end = q0
        call integrator%init(sys, order_m, order_n, gauss_points, status)
        if (.not. status%ok()) return
        ! The fast path gives the plain path's results to round-off (tested in test_speed).
        integrator%newton%simplified = .true.
        integrator%linear_solver = "mixed"
        integrator%newton%presolve = .true.
        energy0 = sys%hamiltonian(q, p)
        do k = 1, nint(span / h)
            call integrator%step(sys, q, p, h, status=status)
            if (.not. status%ok()) return
            energy_error = max(energy_error, abs((sys%hamiltonian(q, p) - energy0) / energy0))
        end do
        q_end = q
    end subroutine run_once

    !> Reference q(span) for global errors: a high-order run at a small step.
    subroutine reference_solution(sys, q0, p0, order_m, h, span, q_ref, status)
        class(constrained_hamiltonian), intent(in) :: sys !! the system
        real(wp), intent(in) :: q0(:)   !! initial coordinates
        real(wp), intent(in) :: p0(:)   !! initial momenta
        integer, intent(in) :: order_m  !! M of the reference (N = M-1, G = M+1)
        real(wp), intent(in) :: h       !! its step size
        real(wp), intent(in) :: span    !! T
        real(wp), intent(out) :: q_ref(:) !! q(T)
        type(holosym_status_t), intent(out) :: status !! outcome
        real(wp) :: energy_error
        call run_once(sys, q0, p0, order_m, order_m - 1, order_m + 1, h, span, energy_error, &
                      q_ref, status)
    end subroutine reference_solution

    !> Measure the energy and global-error orders of one configuration by halving h
    !! through `settings%step_sizes` until the errors reach the floor or the order settles.
    subroutine measure_order(sys, q0, p0, q_ref, settings, cell)
        class(constrained_hamiltonian), intent(in) :: sys !! the system
        real(wp), intent(in) :: q0(:)     !! initial coordinates
        real(wp), intent(in) :: p0(:)     !! initial momenta
        real(wp), intent(in) :: q_ref(:)  !! reference q(T)
        type(study_settings_t), intent(in) :: settings !! step sizes, floor, span
        type(order_cell_t), intent(inout) :: cell !! (M, N, G) in, measurements out
        real(wp) :: energy(size(settings%step_sizes)), global(size(settings%step_sizes))
        real(wp) :: q_end(size(q0))
        type(holosym_status_t) :: status
        integer :: k, first, count_start, count_end, count_rate

        call system_clock(count_start, count_rate)
        cell%levels = 0
        ! The first level measured: the integrator refuses step sizes too large to resolve
        ! the motion (HOLOSYM_STEP_TOO_LARGE); the largest ones are then left out.
        first = 1
        do k = 1, size(settings%step_sizes)
            call run_once(sys, q0, p0, cell%order_m, cell%order_n, cell%gauss_points, &
                          settings%step_sizes(k), settings%span, energy(k), q_end, status)
            if (status%code == HOLOSYM_STEP_TOO_LARGE .and. k == first .and. &
                k < size(settings%step_sizes)) then
                first = k + 1
                cycle
            end if
            if (.not. status%ok()) then
                cell%code = status%code
                cell%message = status%message
                exit
            end if
            global(k) = maxval(abs(q_end - q_ref))
            cell%levels = k - first + 1
            ! Finer steps help neither measure once each is at the floor or has settled.
            if (done(energy(first:k), settings%step_sizes(first:k), settings%error_floor) &
                .and. done(global(first:k), settings%step_sizes(first:k), &
                           settings%global_floor)) exit
        end do
        if (cell%code == HOLOSYM_SUCCESS .or. cell%levels >= 2) then
            associate (last => first + cell%levels - 1)
                call pick_pair(energy(first:last), settings%step_sizes(first:), &
                               settings%error_floor, cell%energy_h, cell%energy_error, &
                               cell%energy_order, cell%energy_measured)
                call pick_pair(global(first:last), settings%step_sizes(first:), &
                               settings%global_floor, cell%global_h, cell%global_error, &
                               cell%global_order, cell%global_measured)
            end associate
        end if
        call system_clock(count_end)
        cell%seconds = real(count_end - count_start, wp) / count_rate

    contains

        !> An error sequence (at step sizes h) needs no finer level: its last value is at
        !! the floor, or its last two orders agree within `settings%settled`.
        pure logical function done(errors, h, floor)
            real(wp), intent(in) :: errors(:), h(:), floor
            real(wp) :: orders(2)
            integer :: last
            last = size(errors)
            done = errors(last) <= floor
            if (done .or. last < 3) return
            orders = log(errors(last - 2:last - 1) / errors(last - 1:last)) / &
                     log(h(last - 2:last - 1) / h(last - 1:last))
            done = abs(orders(2) - orders(1)) <= settings%settled
        end function done

    end subroutine measure_order

    !> The last pair of successive levels with both errors above the floor, and its order.
    pure subroutine pick_pair(errors, step_sizes, floor, h, pair, order, measured)
        real(wp), intent(in) :: errors(:), step_sizes(:), floor
        real(wp), intent(out) :: h(2), pair(2), order
        logical, intent(out) :: measured
        integer :: k
        measured = .false.
        h = 0
        pair = 0
        order = 0
        do k = size(errors), 2, -1
            if (errors(k) > floor .and. errors(k - 1) > floor) then
                h = step_sizes(k - 1:k)
                pair = errors(k - 1:k)
                order = log(pair(1) / pair(2)) / log(h(1) / h(2))
                measured = .true.
                return
            end if
        end do
    end subroutine pick_pair

    !> Measure all cells, in parallel across threads when built with OpenMP, or on the
    !! ranks of `farm` (every rank calls this; the cells are complete on the collector).
    subroutine run_order_cells(sys, q0, p0, q_ref, settings, cells, label, farm)
        class(constrained_hamiltonian), intent(in) :: sys !! the system
        real(wp), intent(in) :: q0(:)     !! initial coordinates
        real(wp), intent(in) :: p0(:)     !! initial momenta
        real(wp), intent(in) :: q_ref(:)  !! reference q(T)
        type(study_settings_t), intent(in) :: settings !! study settings
        type(order_cell_t), intent(inout) :: cells(:)  !! (M, N, G) in, measurements out
        character(len=*), intent(in) :: label          !! name for progress lines
        class(task_farm), intent(inout), optional :: farm !! who computes the cells
        type(cells_job) :: job
        type(holosym_status_t) :: status
        type(progress_clock_t) :: clock
        integer :: i, finished
        if (present(farm)) then
            allocate (job%sys, source=sys)
            job%q0 = q0
            job%p0 = p0
            job%q_ref = q_ref
            job%settings = settings
            job%cells = cells
            job%label = label
            ! Largest configurations first: better load balance.
            call farm%execute(job, [(i, i = size(cells), 1, -1)], status)
            cells = job%cells
            return
        end if
        finished = 0
        call clock%begin()
        !$omp parallel do schedule(dynamic, 1) default(shared) private(i)
        do i = size(cells), 1, -1
            ! Largest configurations first: better load balance.
            call measure_order(sys, q0, p0, q_ref, settings, cells(i))
            !$omp critical (progress_lines)
            finished = finished + 1
            if (settings%progress) call progress_line(clock, label, cells(i), finished, &
                                                      size(cells))
            !$omp end critical (progress_lines)
        end do
        !$omp end parallel do
    end subroutine run_order_cells

    !> The progress line of a measured cell: k/N, the time, its (M, N, G) and its time,
    !! or why it failed.
    subroutine progress_line(clock, label, cell, finished, total)
        type(progress_clock_t), intent(in) :: clock
        character(len=*), intent(in) :: label
        type(order_cell_t), intent(in) :: cell
        integer, intent(in) :: finished, total
        character(len=:), allocatable :: text
        text = "(M, N, G) = (" // int_str(cell%order_m) // ", " // int_str(cell%order_n) // &
            ", " // int_str(cell%gauss_points) // ") " // seconds_text(cell%seconds)
        if (cell%code /= HOLOSYM_SUCCESS) then
            text = text // ", failed: " // status_code_name(cell%code)
            if (allocated(cell%message)) then
                if (len(cell%message) > 0) text = text // ": " // cell%message
            end if
        end if
        call clock%report(error_unit, label // ": ", finished, finished, total, text)
    end subroutine progress_line

    !> Task i: measure cells(i) and pack it.
    subroutine cells_job_run(self, task, record)
        class(cells_job), intent(in) :: self
        integer, intent(in) :: task
        character(len=:), allocatable, intent(out) :: record
        type(order_cell_t) :: cell
        cell = self%cells(task)
        call measure_order(self%sys, self%q0, self%p0, self%q_ref, self%settings, cell)
        if (.not. allocated(cell%message)) cell%message = ""
        record = ""
        call put(record, cell%code)
        call put(record, cell%message)
        call put(record, cell%levels)
        call put(record, cell%energy_h)
        call put(record, cell%energy_error)
        call put(record, cell%energy_order)
        call put(record, cell%energy_measured)
        call put(record, cell%global_h)
        call put(record, cell%global_error)
        call put(record, cell%global_order)
        call put(record, cell%global_measured)
        call put(record, cell%seconds)
    end subroutine cells_job_run

    !> Unpack the measurements of cells(i); a progress line.
    subroutine cells_job_accept(self, task, record, halt)
        class(cells_job), intent(inout) :: self
        integer, intent(in) :: task
        character(len=*), intent(in) :: record
        logical, intent(inout) :: halt
        type(record_reader_t) :: reader
        associate (cell => self%cells(task))
            cell%code = reader%integer(record)
            cell%message = reader%text(record)
            cell%levels = reader%integer(record)
            cell%energy_h = reader%reals(record)
            cell%energy_error = reader%reals(record)
            cell%energy_order = reader%real(record)
            cell%energy_measured = reader%logical(record)
            cell%global_h = reader%reals(record)
            cell%global_error = reader%reals(record)
            cell%global_order = reader%real(record)
            cell%global_measured = reader%logical(record)
            cell%seconds = reader%real(record)
            self%finished = self%finished + 1
            if (self%settings%progress) write (error_unit, '(a)') self%label // ": " // &
                int_str(self%finished) // "/" // int_str(size(self%cells)) // &
                " (M, N, G) = (" // int_str(cell%order_m) // ", " // int_str(cell%order_n) &
                // ", " // int_str(cell%gauss_points) // ") " // seconds_text(cell%seconds)
        end associate
    end subroutine cells_job_accept

    !> Smallest G in 1..max_gauss for which the first step's Newton Jacobian is nonsingular
    !! (LU pivot test with the default relative threshold), or 0 if none is.
    subroutine minimum_gauss_points(sys, q0, p0, order_m, order_n, h, max_gauss, gauss_min, status)
        class(constrained_hamiltonian), intent(in) :: sys !! the system
        real(wp), intent(in) :: q0(:)      !! initial coordinates
        real(wp), intent(in) :: p0(:)      !! initial momenta
        integer, intent(in) :: order_m     !! M
        integer, intent(in) :: order_n     !! N
        real(wp), intent(in) :: h          !! step size of the trial step
        integer, intent(in) :: max_gauss   !! largest G tried
        integer, intent(out) :: gauss_min  !! smallest nonsingular G, 0 if none
        type(holosym_status_t), intent(out), optional :: status !! a failure other than singular
        type(constrained_integrator) :: integrator
        type(holosym_status_t) :: local
        real(wp) :: q(size(q0)), p(size(p0))
        integer :: g

        gauss_min = 0
        if (max_gauss < 1) then
            call set_status(status, HOLOSYM_INVALID_ARGUMENT, "max_gauss must be >= 1; got " // &
                int_str(max_gauss))
            return
        end if
        do g = 1, max_gauss
            q = q0
            p = p0
            call integrator%init(sys, order_m, order_n, g, local)
            if (local%ok()) call integrator%step(sys, q, p, h, status=local)
            if (local%ok()) then
                gauss_min = g
                exit
            end if
            ! G < N + 1 is rejected at init as singular for every system.
            if (local%code /= HOLOSYM_SINGULAR_MATRIX .and. &
                local%code /= HOLOSYM_INVALID_ORDER) then
                call set_status(status, local%code, local%message)
                return
            end if
        end do
        call set_status(status, HOLOSYM_SUCCESS, "")
    end subroutine minimum_gauss_points

    !> "12.34 s" for progress lines.
    function seconds_text(seconds) result(text)
        real(wp), intent(in) :: seconds
        character(len=:), allocatable :: text
        character(len=24) :: buffer
        write (buffer, '(f0.2, " s")') seconds
        text = trim(buffer)
    end function seconds_text

end module holosym_convergence

!> Holds `not_installed`: fpm installs no module of a source with a submodule.
submodule (holosym_convergence) holosym_convergence_app
    implicit none
contains
    module procedure not_installed
    end procedure not_installed
end submodule holosym_convergence_app
