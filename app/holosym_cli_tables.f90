!> The `tables` command: the paper's Tables 1-2 and its minimum-Gauss-point claim,
!! measured. Markdown to the output unit, progress to the error unit, CSV with --csv DIR.
!!
!! Table 1: orders for M = 1..Mmax, N = 0..Nmax with G = max(M, N) + 1, next to the law.
!! Table 2: M = N + 1, N = 1..Mmax-1, G = M .. M+3. Table 3: the smallest G with a
!! nonsingular Newton Jacobian. Each order table has an energy column (E = max_t |e_t|, as
!! in the paper) and a global-error column (max |q(T) - q_ref(T)|).
module holosym_cli_tables
    use, intrinsic :: iso_fortran_env, only: int64
    use holosym_kinds, only: wp
    use holosym_status_codes, only: holosym_status_t, int_str, real_str, status_code_name, &
        HOLOSYM_SUCCESS, HOLOSYM_SINGULAR_MATRIX
    use holosym_problem, only: constrained_hamiltonian
    ! The building blocks, as an expert user takes them.
    use holosym_internal, only: default_pivot_tolerance, farm_job, task_farm, &
        record_reader_t, put
    use holosym_convergence, only: order_cell_t, study_settings_t, paper_order_law, &
        run_order_cells, minimum_gauss_points, reference_solution
    use holosym_scheme, only: max_order_m, max_order_n
    use holosym_output, only: output_t, open_output, make_directories
    use holosym_cli_common, only: parsed_command_proceeds, &
        cli_argument_t, split_option, option_value, parse_integer, parse_integer_in, &
        parse_real, fail, csv_real, csv_integer, join_lines, EXIT_OK, EXIT_FAILURE
    use holosym_systems, only: system_source_t, make_source_system
    implicit none
    private

    public :: tables_options_t, tables_result_t, parse_tables_options, compute_tables, &
              write_tables_markdown, write_tables_csv, tables_command, tables_help

    !> A measured order agrees with the law when within this distance.
    real(wp), parameter :: agreement = 0.3_wp
    !> Default step sizes h = 1/2 .. 1/32 (T = 10 gives 20 .. 320 steps).
    real(wp), parameter :: default_steps(*) = [0.5_wp, 0.25_wp, 0.125_wp, 0.0625_wp, 0.03125_wp]
    !> Default largest M and N of Table 1.
    integer, parameter :: default_max_order = 7
    !> The --quick subset: M, N <= 3 and step sizes down to 1/16.
    integer, parameter :: quick_max_order = 3
    !> Reference solution: M = 8 (order 16) at h = 1/16, checked against h = 1/32.
    integer, parameter :: reference_order = 8
    real(wp), parameter :: reference_step = 0.0625_wp
    !> Global errors must exceed the reference's change by this factor to be used.
    real(wp), parameter :: reference_margin = 100
    !> Table 2 tries G = M .. M + extra_gauss; Table 3 searches G up to max(M, N) + that.
    integer, parameter :: extra_gauss = 3
    !> Step size of the trial step of Table 3.
    real(wp), parameter :: trial_step = 0.125_wp
    !> Table 3 entry of a search that failed for a reason other than singularity.
    integer, parameter :: search_failed = -1
    !> Most steps of one run (T/h for every step size): a bound on the time of a table.
    integer, parameter :: max_run_steps = 1000000

    !> Options of `holosym tables`.
    type :: tables_options_t
        type(system_source_t) :: source          !! built-in system or model file
        real(wp) :: span = 10                    !! T
        real(wp), allocatable :: step_sizes(:)   !! h list, largest first
        integer :: max_m = default_max_order     !! largest M
        integer :: max_n = default_max_order     !! largest N
        logical :: quick = .false.               !! the small subset
        character(len=:), allocatable :: csv_dir !! write CSV files here ("" = none)
        logical :: help = .false.                !! --help given
        logical :: progress = .true.             !! progress lines on the error unit
    end type tables_options_t

    !> Everything the tables show.
    type :: tables_result_t
        character(len=:), allocatable :: system      !! system name
        type(order_cell_t), allocatable :: table1(:) !! M x N grid, G = max(M, N) + 1
        type(order_cell_t), allocatable :: table2(:) !! M = N + 1, G = M .. M + 3
        !> (M, 0:N): smallest nonsingular G; 0 none found, -1 the search failed.
        integer, allocatable :: min_gauss(:, :)
        integer :: max_gauss_tried = 0               !! largest G searched beyond max(M, N) + 1
        real(wp) :: reference_change = 0  !! |q_ref(h) - q_ref(h/2)|: accuracy of the reference
        real(wp) :: seconds = 0           !! wall time
        type(study_settings_t) :: settings
    end type tables_result_t

    !> Table 3 as tasks of a farm: task i is the cell (M, N) of the grid, column-major.
    type, extends(farm_job) :: gauss_job
        class(constrained_hamiltonian), allocatable :: sys
        real(wp), allocatable :: q0(:), p0(:)
        integer :: max_m = 0
        integer :: max_n = 0
        integer, allocatable :: min_gauss(:, :)
    contains
        procedure :: run => gauss_job_run
        procedure :: accept => gauss_job_accept
    end type gauss_job

    interface
        !> Does nothing. Its body, in the submodule at the end of this file, keeps this
        !! application module out of `fpm install` (see fpm.toml).
        module subroutine not_installed()
        end subroutine not_installed
    end interface

contains

    !> The text of `holosym tables --help`.
    pure function tables_help() result(text)
        character(len=:), allocatable :: text !! the help
        text = join_lines([character(len=96) :: &
            "Usage: holosym tables [options]", &
            "", &
            "Measure the convergence orders of the paper's Tables 1-2 and the minimum number", &
            "of Gauss points (Table 3). Markdown on stdout, progress on stderr.", &
            "", &
            "Options:", &
            "  --system NAME   pendulum (default), linkage, planar, double, dumbbell,", &
            "                  magnetic or generic (see holosym simulate --help)", &
            "  --model FILE    the system of a model file instead (docs/models.md)", &
            "  --set NAME=X    set parameter NAME of the model to X (repeatable)", &
            "  --T T           time span of every run, > 0 (default 10)", &
            "  --h LIST        step sizes, largest first, comma separated, > 0", &
            "                  (default 0.5,0.25,0.125,0.0625,0.03125); T/h must give", &
            "                  1..1000000 steps for every step size", &
            "  --Mmax M        largest M of Table 1, 1..30 (default 7)", &
            "  --Nmax N        largest N of Table 1, 0..30 (default 7)", &
            "  --quick         M, N <= 3 and h down to 1/16 (under a minute)", &
            "  --csv DIR       also write DIR/table1.csv, table2.csv, table3.csv (DIR is", &
            "                  created when missing)", &
            "  --help          this text"])
    end function tables_help

    !> Parse the options of `tables`. Failure: HOLOSYM_INVALID_ARGUMENT naming the option.
    subroutine parse_tables_options(args, options, status)
        type(cli_argument_t), intent(in) :: args(:)    !! the command's arguments
        type(tables_options_t), intent(out) :: options !! parsed settings
        type(holosym_status_t), intent(out) :: status  !! outcome
        character(len=:), allocatable :: name, inline, value
        logical :: has_inline, h_given, m_given, n_given, taken
        integer :: i

        options%csv_dir = ""
        status%code = HOLOSYM_SUCCESS
        status%message = ""
        h_given = .false.
        m_given = .false.
        n_given = .false.
        i = 1
        do while (i <= size(args))
            call split_option(args(i)%text, name, inline, has_inline)
            select case (name)
            case ("-h", "--help")
                options%help = .true.
                return
            case ("--quick")
                options%quick = .true.
            case ("--system", "--model", "--set", "--T", "--h", "--Mmax", "--Nmax", "--csv")
                call option_value(args, i, name, inline, has_inline, value, status)
                if (.not. status%ok()) return
                call options%source%take(name, value, taken, status)
                if (.not. status%ok()) return
                select case (name)
                case ("--T")
                    call parse_real(name, value, options%span, status)
                    if (status%ok() .and. .not. options%span > 0) call fail(status, &
                        "option --T must be > 0; got '" // value // "'")
                case ("--h")
                    call parse_step_list(value, options%step_sizes, status)
                    h_given = .true.
                case ("--Mmax")
                    call parse_integer_in(name, value, 1, max_order_m, options%max_m, status)
                    m_given = .true.
                case ("--Nmax")
                    call parse_integer_in(name, value, 0, max_order_n, options%max_n, status)
                    n_given = .true.
                case ("--csv")
                    options%csv_dir = value
                end select
                if (.not. status%ok()) return
            case default
                call fail(status, "unknown option '" // args(i)%text // "'")
                return
            end select
            i = i + 1
        end do
        if (options%quick) then
            if (.not. m_given) options%max_m = quick_max_order
            if (.not. n_given) options%max_n = quick_max_order
            if (.not. h_given) options%step_sizes = default_steps(1:4)
        end if
        if (.not. h_given .and. .not. options%quick) options%step_sizes = default_steps
        call options%source%check(status)
        if (.not. status%ok()) return
        call check_step_counts(options%span, options%step_sizes, status)
    end subroutine parse_tables_options

    !> Every run takes nint(T/h) steps: 1..max_run_steps for each step size (decided on the
    !! exponents first, so that T/h cannot overflow).
    subroutine check_step_counts(span, step_sizes, status)
        real(wp), intent(in) :: span           !! T > 0
        real(wp), intent(in) :: step_sizes(:)  !! h > 0
        type(holosym_status_t), intent(inout) :: status
        integer :: k
        real(wp) :: ratio
        do k = 1, size(step_sizes)
            ratio = huge(1.0_wp)
            if (exponent(span) - exponent(step_sizes(k)) <= bit_size(max_run_steps)) &
                ratio = span / step_sizes(k)
            if (ratio > max_run_steps) then
                call fail(status, "options --T and --h: T/h is more than " // &
                    int_str(max_run_steps) // " steps for h = " // step_text(step_sizes(k)))
                return
            else if (nint(ratio) < 1) then
                call fail(status, "options --T and --h: T/h rounds to 0 steps for h = " // &
                    step_text(step_sizes(k)) // " (T is less than h/2)")
                return
            end if
        end do
    end subroutine check_step_counts

    !> Parse "0.5,0.25,..." into step sizes: at least two, positive, strictly decreasing.
    subroutine parse_step_list(text, steps, status)
        character(len=*), intent(in) :: text
        real(wp), allocatable, intent(out) :: steps(:)
        type(holosym_status_t), intent(out) :: status
        integer :: first, comma
        real(wp) :: value
        allocate (steps(0))
        status%code = HOLOSYM_SUCCESS
        status%message = ""
        first = 1
        do
            comma = index(text(first:), ",")
            if (comma == 0) then
                call parse_real("--h", text(first:), value, status)
            else
                call parse_real("--h", text(first:first + comma - 2), value, status)
            end if
            if (.not. status%ok()) return
            if (.not. value > 0) then
                call fail(status, "option --h: step sizes must be > 0; got '" // text // "'")
                return
            end if
            steps = [steps, value]
            if (comma == 0) exit
            first = first + comma
        end do
        if (size(steps) < 2) then
            call fail(status, "option --h needs at least two step sizes; got '" // text // "'")
        else if (any(steps(2:) >= steps(:size(steps) - 1))) then
            call fail(status, "option --h: step sizes must decrease; got '" // text // "'")
        end if
    end subroutine parse_step_list

    !> Run the three studies: the cells on OpenMP threads, or on the ranks of `farm` (every
    !! rank calls this; `result` is complete on the collector).
    subroutine compute_tables(options, result, err_unit, status, farm)
        type(tables_options_t), intent(in) :: options  !! parsed settings
        type(tables_result_t), intent(out) :: result   !! measurements
        integer, intent(in) :: err_unit                !! progress lines
        type(holosym_status_t), intent(out) :: status  !! outcome
        class(task_farm), intent(inout), optional :: farm !! who computes the cells
        type(gauss_job) :: job
        class(constrained_hamiltonian), allocatable :: sys
        real(wp), allocatable :: q0(:), p0(:), q_ref(:), q_check(:)
        type(holosym_status_t) :: ref_status(2)
        type(holosym_status_t), allocatable :: search_status(:, :)
        integer :: order_m, order_n, i, max_n_table2
        integer(int64) :: count_start, count_end, count_rate
        character(len=:), allocatable :: note

        call system_clock(count_start, count_rate)
        call make_source_system(options%source, sys, q0, p0, status, note)
        if (.not. status%ok()) return
        if (len(note) > 0 .and. options%progress) write (err_unit, '(a)') &
            "holosym tables: note: " // note
        result%system = options%source%label()
        result%settings%span = options%span
        result%settings%step_sizes = options%step_sizes
        result%settings%progress = options%progress
        allocate (q_ref(size(q0)), q_check(size(q0)))
        !$omp parallel sections
        call reference_solution(sys, q0, p0, reference_order, reference_step, options%span, &
                                q_ref, ref_status(1))
        !$omp section
        call reference_solution(sys, q0, p0, reference_order, reference_step / 2, &
                                options%span, q_check, ref_status(2))
        !$omp end parallel sections
        do i = 1, 2
            if (.not. ref_status(i)%ok()) then
                status = ref_status(i)
                status%message = "reference solution: " // status%message
                return
            end if
        end do
        result%reference_change = maxval(abs(q_ref - q_check))
        q_ref = q_check
        ! Global errors near the reference's own error say nothing about the order.
        result%settings%global_floor = max(result%settings%error_floor, &
                                           reference_margin * result%reference_change)
        if (options%progress) write (err_unit, '(a)') "tables: reference (M = " // &
            int_str(reference_order) // ") changes by " // real_str(result%reference_change) &
            // " from h = 1/16 to 1/32"

        allocate (result%table1(options%max_m * (options%max_n + 1)))
        i = 0
        do order_m = 1, options%max_m
            do order_n = 0, options%max_n
                i = i + 1
                result%table1(i)%order_m = order_m
                result%table1(i)%order_n = order_n
                result%table1(i)%gauss_points = max(order_m, order_n) + 1
            end do
        end do
        call run_order_cells(sys, q0, p0, q_ref, result%settings, result%table1, "table 1", &
                             farm)

        max_n_table2 = max(options%max_m - 1, 1)
        allocate (result%table2(max_n_table2 * (extra_gauss + 1)))
        i = 0
        do order_n = 1, max_n_table2
            do order_m = 0, extra_gauss
                i = i + 1
                result%table2(i)%order_m = order_n + 1
                result%table2(i)%order_n = order_n
                result%table2(i)%gauss_points = order_n + 1 + order_m
            end do
        end do
        call run_order_cells(sys, q0, p0, q_ref, result%settings, result%table2, "table 2", &
                             farm)

        allocate (result%min_gauss(options%max_m, 0:options%max_n))
        allocate (search_status(options%max_m, 0:options%max_n))
        if (present(farm)) then
            allocate (job%sys, source=sys)
            job%q0 = q0
            job%p0 = p0
            job%max_m = options%max_m
            job%max_n = options%max_n
            allocate (job%min_gauss(options%max_m, 0:options%max_n), source=0)
            call farm%execute(job, [(i, i = size(job%min_gauss), 1, -1)], status)
            if (.not. status%ok()) return
            result%min_gauss = job%min_gauss
        else
            !$omp parallel do collapse(2) schedule(dynamic, 1) private(order_m, order_n)
            do order_m = 1, options%max_m
                do order_n = 0, options%max_n
                    call minimum_gauss_points(sys, q0, p0, order_m, order_n, trial_step, &
                        max(order_m, order_n) + extra_gauss, result%min_gauss(order_m, order_n), &
                        search_status(order_m, order_n))
                    ! A failure other than a singular Jacobian is shown as such, not as "none".
                    if (.not. search_status(order_m, order_n)%ok()) &
                        result%min_gauss(order_m, order_n) = search_failed
                end do
            end do
            !$omp end parallel do
        end if
        result%max_gauss_tried = extra_gauss
        call system_clock(count_end)
        result%seconds = real(count_end - count_start, wp) / count_rate
        status%code = HOLOSYM_SUCCESS
        status%message = ""
    end subroutine compute_tables

    !> Task i: the minimum-G search of grid cell i (M = 1 + mod(i - 1, max_m)).
    subroutine gauss_job_run(self, task, record)
        class(gauss_job), intent(in) :: self
        integer, intent(in) :: task
        character(len=:), allocatable, intent(out) :: record
        type(holosym_status_t) :: search_status
        integer :: order_m, order_n, gauss_min
        order_m = 1 + mod(task - 1, self%max_m)
        order_n = (task - 1) / self%max_m
        call minimum_gauss_points(self%sys, self%q0, self%p0, order_m, order_n, trial_step, &
            max(order_m, order_n) + extra_gauss, gauss_min, search_status)
        ! A failure other than a singular Jacobian is shown as such, not as "none".
        if (.not. search_status%ok()) gauss_min = search_failed
        record = ""
        call put(record, gauss_min)
    end subroutine gauss_job_run

    !> Store the result of grid cell i.
    subroutine gauss_job_accept(self, task, record, halt)
        class(gauss_job), intent(inout) :: self
        integer, intent(in) :: task
        character(len=*), intent(in) :: record
        logical, intent(inout) :: halt
        type(record_reader_t) :: reader
        self%min_gauss(1 + mod(task - 1, self%max_m), (task - 1) / self%max_m) = &
            reader%integer(record)
    end subroutine gauss_job_accept

    !> "1/8" for reciprocals of integers, else the decimal value.
    function step_text(h) result(text)
        real(wp), intent(in) :: h
        character(len=:), allocatable :: text
        real(wp) :: inverse
        character(len=32) :: buffer
        logical :: is_reciprocal
        inverse = 1 / h
        is_reciprocal = .false.
        ! nint only where it fits the default integer.
        if (h < 1 .and. inverse < huge(1) / 2) is_reciprocal = &
            abs(inverse - nint(inverse)) <= 8 * epsilon(1.0_wp) * inverse
        if (is_reciprocal) then
            text = "1/" // int_str(nint(inverse))
        else
            write (buffer, '(g0.6)') real(h)
            text = trim(adjustl(buffer))
        end if
    end function step_text

    !> Fixed-point text with two decimals.
    function order_text(order) result(text)
        real(wp), intent(in) :: order
        character(len=:), allocatable :: text
        character(len=16) :: buffer
        write (buffer, '(f8.2)') order
        text = trim(adjustl(buffer))
    end function order_text

    !> A table cell: "r / law ok (h1, h2)", or why there is no number.
    function cell_text(cell, energy, law) result(text)
        type(order_cell_t), intent(in) :: cell
        logical, intent(in) :: energy  !! energy order (else global order)
        integer, intent(in) :: law     !! the paper's order, < 0 for none
        character(len=:), allocatable :: text
        real(wp) :: order, h(2)
        logical :: measured
        if (cell%code == HOLOSYM_SINGULAR_MATRIX) then
            text = "singular"
            return
        else if (cell%code /= HOLOSYM_SUCCESS .and. cell%levels < 2) then
            text = "failed (" // status_code_name(cell%code) // ")"
            return
        end if
        if (energy) then
            order = cell%energy_order
            h = cell%energy_h
            measured = cell%energy_measured
        else
            order = cell%global_order
            h = cell%global_h
            measured = cell%global_measured
        end if
        if (.not. measured) then
            text = "at floor"
            return
        end if
        text = order_text(order)
        if (law >= 0) then
            if (abs(order - law) <= agreement) then
                text = text // " / " // int_str(law) // " ok"
            else
                text = text // " / " // int_str(law) // " **no**"
            end if
        end if
        text = text // " (" // step_text(h(1)) // ", " // step_text(h(2)) // ")"
    end function cell_text

    !> Write the three tables and a summary as Markdown.
    subroutine write_tables_markdown(result, out)
        type(tables_result_t), intent(in) :: result !! measurements
        type(output_t), intent(inout) :: out        !! where the Markdown goes
        integer :: max_m, max_n, order_m, order_n, i, g, agree, measured, singular
        character(len=:), allocatable :: line
        logical :: energy

        max_m = size(result%min_gauss, 1)
        max_n = size(result%min_gauss, 2) - 1
        call out%line("### holosym tables: system " // result%system // ", T = " // &
            order_text(result%settings%span) // ", step sizes " // step_list(result))
        call out%line("")
        call out%line("Cells: measured order / paper's law, ok when within " // &
            order_text(agreement) // ", and the step pair (h1, h2) used. Energy error " // &
            "E = max_t |(H_t - H_0)/H_0|; global error max|q(T) - q_ref(T)| against M = " // &
            int_str(reference_order) // ", h = 1/32 (which differs from h = 1/16 by " // &
            real_str(result%reference_change) // "). Energy errors below " // &
            real_str(result%settings%error_floor) // " and global errors below " // &
            real_str(result%settings%global_floor) // " (100 times that change, at least " // &
            "the same floor) are not used.")
        do i = 1, 2
            energy = i == 1
            call out%line("")
            if (energy) then
                call out%line("#### Table 1: order of the energy error, G = max(M, N) + 1")
            else
                call out%line("#### Table 1b: order of the global error of q(T), " // &
                    "G = max(M, N) + 1")
            end if
            call write_grid_header(out, max_n)
            do order_m = 1, max_m
                line = "| " // int_str(order_m) // " |"
                do order_n = 0, max_n
                    line = line // " " // cell_text(result%table1((order_m - 1) * (max_n + 1) &
                        + order_n + 1), energy, paper_order_law(order_m, order_n)) // " |"
                end do
                call out%line(line)
            end do
            call count_agreement(result%table1, energy, agree, measured, singular)
            call out%line("")
            call out%line(int_str(agree) // " of " // int_str(measured) // &
                " measured cells agree with the law; " // int_str(singular) // " singular.")
        end do

        call out%line("")
        call out%line("#### Table 2: orders for M = N + 1 and G = M .. M + " // &
            int_str(extra_gauss) // " (energy; global)")
        call out%line("")
        line = "| N | M |"
        do g = 0, extra_gauss
            line = line // " G = M + " // int_str(g) // " |"
        end do
        call out%line(line)
        call out%line("|---|---|" // repeat("---|", extra_gauss + 1))
        do i = 1, size(result%table2), extra_gauss + 1
            line = "| " // int_str(result%table2(i)%order_n) // " | " // &
                int_str(result%table2(i)%order_m) // " |"
            do g = 0, extra_gauss
                line = line // " " // cell_text(result%table2(i + g), .true., &
                    paper_order_law(result%table2(i)%order_m, result%table2(i)%order_n)) // &
                    "; " // cell_text(result%table2(i + g), .false., -1) // " |"
            end do
            call out%line(line)
        end do
        call count_agreement(result%table2, .true., agree, measured, singular)
        call out%line("")
        call out%line("Energy: " // int_str(agree) // " of " // int_str(measured) // &
            " measured cells agree with the law; " // int_str(singular) // " singular.")

        call out%line("")
        call out%line("#### Table 3: smallest G with a nonsingular Newton Jacobian " // &
            "(paper: max(M, N) + 1)")
        call out%line("")
        call out%line("One step of h = " // step_text(trial_step) // " from the " // &
            "initial state for G = 1, 2, ...; singular when a pivot of the row-equilibrated " // &
            "Jacobian is <= n_x * epsilon (n_x unknowns, e.g. " // &
            real_str(default_pivot_tolerance(50)) // " for n_x = 50). Cell: found / paper.")
        call write_grid_header(out, max_n)
        agree = 0
        do order_m = 1, max_m
            line = "| " // int_str(order_m) // " |"
            do order_n = 0, max_n
                g = result%min_gauss(order_m, order_n)
                if (g == search_failed) then
                    line = line // " failed |"
                else if (g == 0) then
                    line = line // " none <= " // int_str(max(order_m, order_n) + extra_gauss) &
                        // " / " // int_str(max(order_m, order_n) + 1) // " |"
                else
                    line = line // " " // int_str(g) // " / " // &
                        int_str(max(order_m, order_n) + 1) // " |"
                    if (g == max(order_m, order_n) + 1) agree = agree + 1
                end if
            end do
            call out%line(line)
        end do
        call out%line("")
        call out%line(int_str(agree) // " of " // int_str(size(result%min_gauss)) // &
            " cells have the paper's minimum G; " // &
            int_str(count(result%min_gauss == 0)) // " are singular for every G tried.")
        call out%line("")
        call out%line("Wall time: " // order_text(result%seconds) // " s")
    end subroutine write_tables_markdown

    !> A blank line and the header of an M x N grid table with columns N = 0..max_n.
    subroutine write_grid_header(out, max_n)
        type(output_t), intent(inout) :: out
        integer, intent(in) :: max_n
        character(len=:), allocatable :: line
        integer :: order_n
        call out%line("")
        line = "| M \ N |"
        do order_n = 0, max_n
            line = line // " " // int_str(order_n) // " |"
        end do
        call out%line(line)
        call out%line("|---|" // repeat("---|", max_n + 1))
    end subroutine write_grid_header

    function step_list(result) result(text)
        type(tables_result_t), intent(in) :: result
        character(len=:), allocatable :: text
        integer :: k
        text = ""
        do k = 1, size(result%settings%step_sizes)
            if (k > 1) text = text // ", "
            text = text // step_text(result%settings%step_sizes(k))
        end do
    end function step_list

    pure subroutine count_agreement(cells, energy, agree, measured, singular)
        type(order_cell_t), intent(in) :: cells(:)
        logical, intent(in) :: energy
        integer, intent(out) :: agree, measured, singular
        integer :: i, law
        agree = 0
        measured = 0
        singular = count(cells%code == HOLOSYM_SINGULAR_MATRIX)
        do i = 1, size(cells)
            law = paper_order_law(cells(i)%order_m, cells(i)%order_n)
            if (energy .and. cells(i)%energy_measured) then
                measured = measured + 1
                if (abs(cells(i)%energy_order - law) <= agreement) agree = agree + 1
            else if (.not. energy .and. cells(i)%global_measured) then
                measured = measured + 1
                if (abs(cells(i)%global_order - law) <= agreement) agree = agree + 1
            end if
        end do
    end subroutine count_agreement

    !> Write DIR/table1.csv, table2.csv (one row per cell) and table3.csv. Failure
    !! (HOLOSYM_INVALID_ARGUMENT): a file that cannot be opened or written (also a full
    !! disk), named with the system's reason.
    subroutine write_tables_csv(result, dir, status)
        type(tables_result_t), intent(in) :: result   !! measurements
        character(len=*), intent(in) :: dir           !! existing directory
        type(holosym_status_t), intent(out) :: status !! I/O failure
        type(output_t) :: file
        integer :: order_m, order_n
        call write_cells(dir // "/table1.csv", result%table1)
        if (.not. status%ok()) return
        call write_cells(dir // "/table2.csv", result%table2)
        if (.not. status%ok()) return
        call open_output(dir // "/table3.csv", file, status)
        if (.not. status%ok()) return
        call file%line("system,M,N,min_G_found,paper_min_G,max_G_tried")
        do order_m = 1, size(result%min_gauss, 1)
            do order_n = 0, size(result%min_gauss, 2) - 1
                call file%line(result%system // "," // int_str(order_m) // "," // &
                    int_str(order_n) // "," // int_str(result%min_gauss(order_m, order_n)) // &
                    "," // int_str(max(order_m, order_n) + 1) // "," // &
                    int_str(max(order_m, order_n) + extra_gauss))
            end do
        end do
        call file%close(status)
    contains
        subroutine write_cells(path, cells)
            character(len=*), intent(in) :: path
            type(order_cell_t), intent(in) :: cells(:)
            integer :: i
            call open_output(path, file, status)
            if (.not. status%ok()) return
            call file%line("system,M,N,G,law,status,energy_h1,energy_h2,energy_E1," // &
                "energy_E2,energy_order,global_h1,global_h2,global_e1,global_e2," // &
                "global_order,seconds")
            do i = 1, size(cells)
                call file%line(result%system // "," // int_str(cells(i)%order_m) // "," &
                    // int_str(cells(i)%order_n) // "," // int_str(cells(i)%gauss_points) // &
                    "," // int_str(paper_order_law(cells(i)%order_m, cells(i)%order_n)) // "," &
                    // csv_integer(cells(i)%code) // "," // csv_real(cells(i)%energy_h(1)) // &
                    "," // csv_real(cells(i)%energy_h(2)) // "," // &
                    csv_real(cells(i)%energy_error(1)) // "," // &
                    csv_real(cells(i)%energy_error(2)) // "," // &
                    csv_real(cells(i)%energy_order) // "," // csv_real(cells(i)%global_h(1)) // &
                    "," // csv_real(cells(i)%global_h(2)) // "," // &
                    csv_real(cells(i)%global_error(1)) // "," // &
                    csv_real(cells(i)%global_error(2)) // "," // &
                    csv_real(cells(i)%global_order) // "," // csv_real(cells(i)%seconds))
            end do
            call file%close(status)
        end subroutine write_cells
    end subroutine write_tables_csv

    !> `holosym tables [options]`: parse, compute, write. Exit 0 success, 1 failure, 2 usage.
    !! With `farm` (holosym-mpi) the cells run on its ranks and only the collector writes.
    subroutine tables_command(args, out, err_unit, exit_code, farm)
        type(cli_argument_t), intent(in) :: args(:) !! the command's arguments
        type(output_t), intent(inout) :: out !! Markdown tables
        integer, intent(in) :: err_unit   !! progress and errors
        integer, intent(out) :: exit_code !! process exit code
        class(task_farm), intent(inout), optional :: farm !! who computes the cells
        type(tables_options_t) :: options
        type(tables_result_t) :: result
        type(holosym_status_t) :: status

        call parse_tables_options(args, options, status)
        if (.not. parsed_command_proceeds("tables", status, options%help, tables_help(), &
                                          out, err_unit, exit_code)) return
        ! The directory first: a run must not end with results it cannot keep.
        if (len(options%csv_dir) > 0) call make_directories(options%csv_dir, status)
        if (status%ok()) call compute_tables(options, result, err_unit, status, farm)
        if (present(farm)) then
            if (.not. farm%is_collector()) then
                exit_code = merge(EXIT_OK, EXIT_FAILURE, status%ok())
                return
            end if
        end if
        if (status%ok()) call write_tables_markdown(result, out)
        if (status%ok() .and. len(options%csv_dir) > 0) &
            call write_tables_csv(result, options%csv_dir, status)
        if (.not. status%ok()) then
            write (err_unit, '(a)') "holosym tables: " // status%message
            exit_code = EXIT_FAILURE
            return
        end if
        exit_code = EXIT_OK
    end subroutine tables_command

end module holosym_cli_tables

!> Holds `not_installed`: fpm installs no module of a source with a submodule.
submodule (holosym_cli_tables) holosym_cli_tables_app
    implicit none
contains
    module procedure not_installed
    end procedure not_installed
end submodule holosym_cli_tables_app
