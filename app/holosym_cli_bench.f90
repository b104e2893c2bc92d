!> The `bench` command: work-precision benchmark of holosym against RATTLE compositions,
!! and the per-step cost of the speed options against the plain path.
!!
!! Writes DIR/bench.csv (bench64.csv in the real64 build), DIR/steps.csv (per-step
!! comparison), DIR/reference.csv (real128 build) and DIR/summary.md; the summary also
!! goes to the output unit. `--summarize DIR` only rebuilds DIR/summary.md from the CSV
!! files there (after a real64 run has added bench64.csv). tools/plot_bench.py draws the
!! work-precision plot from the CSV files.
module holosym_cli_bench
    use, intrinsic :: iso_fortran_env, only: real64, int64
    use holosym_kinds, only: wp, wp_is_double
    use holosym_status, only: holosym_status_t, int_str, real_str, status_code_name, &
        HOLOSYM_SUCCESS
    use holosym_problem, only: constrained_hamiltonian
    use holosym_benchmark, only: bench_row_t, bench_settings_t, reference_state, holosym_run, &
        sweep_holosym, sweep_rattle, variant_name, bench_span, competitor_seconds, &
        competitor_targets, bench_targets, variant_count
    use holosym_output, only: output_t, open_output, make_directories
    use holosym_cli_common, only: parsed_command_proceeds, &
        cli_argument_t, split_option, option_value, parse_integer, parse_integer_in, &
        parse_real, fail, csv_real, csv_integer, join_lines, EXIT_OK, EXIT_FAILURE
    use holosym_systems, only: make_system, system_choices
    implicit none
    private

    public :: bench_options_t, parse_bench_options, bench_command, bench_help, &
              read_bench_csv, write_bench_csv, write_summary

    !> Systems of the benchmark, in the order of the competitor table.
    character(len=*), parameter :: bench_systems(3) = [character(len=8) :: &
        "pendulum", "linkage", "planar"]
    !> Step of the reference pair (h and h/2) per system.
    real(wp), parameter :: reference_steps(3) = [0.0625_wp, 0.0625_wp, 0.0625_wp]
    !> Per-step comparison: spherical pendulum, h = 1/8, T = 10, at (2,1,3) and (7,6,8).
    real(wp), parameter :: per_step_h = 0.125_wp
    integer, parameter :: per_step_configs(3, 2) = reshape([2, 1, 3, 7, 6, 8], [3, 2])
    !> Largest step of the sweeps.
    real(wp), parameter :: sweep_h0 = 1
    !> Largest --budget, in CPU seconds per run.
    real(wp), parameter :: max_budget = 3600
    !> Largest time of a run read back by --summarize (a bound that keeps ratios finite).
    real(wp), parameter :: max_seconds = 1.0e12_wp
    !> Method of a per-step row: this prefix and the option set 0 .. variant_count.
    character(len=*), parameter :: variant_prefix = "variant-"
    !> CSV header of bench rows.
    character(len=*), parameter :: csv_header = "system,method,precision,M,N,G,order,h," // &
        "steps,error,energy_error,constraint_residual,seconds,seconds_per_step," // &
        "newton_iterations,residual_evaluations,gradient_evaluations,hessian_evaluations," // &
        "lu_factorizations,status,difference_from_plain"

    !> Options of `holosym bench`.
    type :: bench_options_t
        character(len=:), allocatable :: out_dir     !! output directory
        character(len=:), allocatable :: reference   !! reference file to read ("" = compute)
        character(len=:), allocatable :: summarize   !! only summarize this directory
        character(len=:), allocatable :: systems     !! comma list (default all three)
        integer :: max_m = 8                         !! largest M
        integer :: max_rattle_order = 10             !! largest composition order
        real(real64) :: budget = 1.5_real64          !! CPU seconds per run before stopping
        logical :: quick = .false.                   !! M <= 4, order <= 6, budget 0.2 s
        logical :: per_step = .true.                 !! run the per-step comparison
        logical :: help = .false.                    !! --help given
    end type bench_options_t

    interface
        !> Does nothing. Its body, in the submodule at the end of this file, keeps this
        !! application module out of `fpm install` (see fpm.toml).
        module subroutine not_installed()
        end subroutine not_installed
    end interface

contains

    !> The text of `holosym bench --help`.
    pure function bench_help() result(text)
        character(len=:), allocatable :: text !! the help
        text = join_lines([character(len=96) :: &
            "Usage: holosym bench [options]", &
            "", &
            "Work-precision benchmark: holosym (M = 1..8, N = M-1, G = M and M+1, fast options)", &
            "against RATTLE composed to orders 2-10 (triple jump, Suzuki) inside holosym, on", &
            "the spherical pendulum (T = 10), spring-linkage (T = 10), planar pendulum", &
            "(T = 100);", &
            "and the per-step cost of each speed option against the plain path.", &
            "", &
            "Options:", &
            "  --out DIR        output directory, created when missing (default build/bench)", &
            "  --systems LIST   comma list of pendulum, linkage, planar (default all)", &
            "  --Mmax M         largest M, 1..12 (default 8)", &
            "  --order P        largest RATTLE composition order, 2..10 (default 10)", &
            "  --budget S       stop refining h once a run takes S CPU seconds, 0 < S <= 3600", &
            "                   (default 1.5)", &
            "  --quick          M <= 4, orders <= 6, budget 0.2 s (about a minute)", &
            "  --no-per-step    skip the per-step comparison", &
            "  --reference FILE read the reference states (the real64 build uses the", &
            "                   real128 one): lines system,q|p,index,value with finite", &
            "                   values, every index of q and p of a system exactly once", &
            "  --summarize DIR  only rebuild DIR/summary.md from DIR/bench.csv and bench64.csv", &
            "  --help           this text", &
            "", &
            "Files: DIR/bench.csv (bench64.csv in the real64 build), DIR/steps.csv,", &
            "DIR/reference.csv, DIR/summary.md. Plot: python3 tools/plot_bench.py DIR."])
    end function bench_help

    !> Parse the options of `bench`. Failure: HOLOSYM_INVALID_ARGUMENT naming the option.
    subroutine parse_bench_options(args, options, status)
        type(cli_argument_t), intent(in) :: args(:)   !! the command's arguments
        type(bench_options_t), intent(out) :: options !! parsed settings
        type(holosym_status_t), intent(out) :: status !! outcome
        character(len=:), allocatable :: name, inline, value
        logical :: has_inline
        real(wp) :: budget
        integer :: i
        options%out_dir = "build/bench"
        options%reference = ""
        options%summarize = ""
        options%systems = "pendulum,linkage,planar"
        status%code = HOLOSYM_SUCCESS
        status%message = ""
        i = 1
        do while (i <= size(args))
            call split_option(args(i)%text, name, inline, has_inline)
            select case (name)
            case ("-h", "--help")
                options%help = .true.
                return
            case ("--quick")
                options%quick = .true.
                options%max_m = 4
                options%max_rattle_order = 6
                options%budget = 0.2_real64
            case ("--no-per-step")
                options%per_step = .false.
            case ("--out", "--systems", "--Mmax", "--order", "--budget", "--reference", &
                  "--summarize")
                call option_value(args, i, name, inline, has_inline, value, status)
                if (.not. status%ok()) return
                select case (name)
                case ("--out")
                    options%out_dir = value
                case ("--reference")
                    options%reference = value
                case ("--summarize")
                    options%summarize = value
                case ("--systems")
                    options%systems = value
                    call check_systems(value, status)
                case ("--Mmax")
                    call parse_integer_in(name, value, 1, 12, options%max_m, status)
                case ("--order")
                    call parse_integer_in(name, value, 2, 10, options%max_rattle_order, status)
                case ("--budget")
                    call parse_real(name, value, budget, status)
                    if (status%ok() .and. .not. (budget > 0 .and. budget <= max_budget)) &
                        call fail(status, "option --budget must be in (0, 3600]; got '" // &
                        value // "'")
                    options%budget = real(budget, real64)
                end select
                if (.not. status%ok()) return
            case default
                call fail(status, "unknown option '" // args(i)%text // "'")
                return
            end select
            i = i + 1
        end do
    end subroutine parse_bench_options

    !> Every name of a comma list must be a benchmark system.
    subroutine check_systems(list, status)
        character(len=*), intent(in) :: list
        type(holosym_status_t), intent(inout) :: status
        integer :: first, comma, last
        first = 1
        do
            comma = index(list(first:), ",")
            last = len(list)
            if (comma > 0) last = first + comma - 2
            if (.not. any(bench_systems == list(first:last))) then
                call fail(status, "option --systems: unknown system '" // list(first:last) // &
                    "'; choose " // system_choices)
                return
            end if
            if (comma == 0) exit
            first = first + comma
        end do
    end subroutine check_systems

    !> True when `system` is in the comma list.
    pure logical function selected(list, system)
        character(len=*), intent(in) :: list, system
        selected = index("," // list // ",", "," // trim(system) // ",") > 0
    end function selected

    !> One CSV line of a row.
    function csv_line(row) result(line)
        type(bench_row_t), intent(in) :: row
        character(len=:), allocatable :: line
        line = trim(row%system) // "," // trim(row%method) // "," // trim(row%precision) // "," &
            // csv_integer(row%order_m) // "," // csv_integer(row%order_n) // "," // &
            csv_integer(row%gauss_points) // "," // csv_integer(row%order) // "," // &
            csv_real(row%h) // "," // csv_integer(row%steps) // "," // csv_real(row%error) // &
            "," // csv_real(row%energy_error) // "," // csv_real(row%constraint_residual) // &
            "," // csv_real(real(row%seconds, wp)) // "," // &
            csv_real(real(row%seconds, wp) / max(row%steps, 1)) // "," // &
            int64_str(row%newton_iterations) // "," // int64_str(row%residuals) // "," // &
            int64_str(row%gradients) // "," // int64_str(row%hessians) // "," // &
            int64_str(row%factorizations) // "," // csv_integer(row%code) // "," // &
            csv_real(row%difference)
    end function csv_line

    pure function int64_str(value) result(text)
        integer(int64), intent(in) :: value
        character(len=:), allocatable :: text
        character(len=24) :: buffer
        write (buffer, '(i0)') value
        text = trim(buffer)
    end function int64_str

    !> Write rows as CSV (the header line, then one line per row), the format
    !! `read_bench_csv` reads. Failure: HOLOSYM_INVALID_ARGUMENT naming the file and the
    !! system's reason (also a full disk).
    subroutine write_bench_csv(path, rows, status)
        character(len=*), intent(in) :: path        !! file, replaced
        type(bench_row_t), intent(in) :: rows(:)    !! rows to write
        type(holosym_status_t), intent(inout) :: status !! I/O failure
        type(output_t) :: file
        integer :: i
        call open_output(path, file, status)
        if (.not. status%ok()) return
        call file%line(csv_header)
        do i = 1, size(rows)
            call file%line(csv_line(rows(i)))
        end do
        call file%close(status)
    end subroutine write_bench_csv

    !> Read rows written by `write_bench_csv` and append them to `rows`. A missing file
    !! gives no rows and no error when `optional_file`. Failure (HOLOSYM_INVALID_ARGUMENT:
    !! an unreadable file, no bench header, a line without 21 fields, a field that is not a
    !! number or out of its range, a per-step row whose method is not variant-0 ..
    !! variant-9) names the file, the line and the field; `rows` is then unchanged. Ranges:
    !! finite reals (no NaN or Inf); h > 0; M, N, G, order, steps, the errors, seconds
    !! (at most 1e12), the work counts and the difference >= 0; status a documented code.
    subroutine read_bench_csv(path, rows, status, optional_file)
        character(len=*), intent(in) :: path !! CSV file
        type(bench_row_t), allocatable, intent(inout) :: rows(:) !! rows are appended
        type(holosym_status_t), intent(inout) :: status !! I/O or format failure
        logical, intent(in), optional :: optional_file !! a missing file is not an error
        integer, parameter :: field_count = 21
        character(len=*), parameter :: field_names(field_count) = [character(len=21) :: &
            "system", "method", "precision", "M", "N", "G", "order", "h", "steps", "error", &
            "energy_error", "constraint_residual", "seconds", "seconds_per_step", &
            "newton_iterations", "residual_evaluations", "gradient_evaluations", &
            "hessian_evaluations", "lu_factorizations", "status", "difference_from_plain"]
        character(len=1024) :: line
        character(len=256) :: message
        character(len=64) :: fields(field_count)
        type(bench_row_t), allocatable :: read_rows(:)
        type(bench_row_t) :: row
        real(wp) :: value
        integer :: unit, ios, first, k, comma, line_number
        logical :: exists
        inquire (file=path, exist=exists)
        if (.not. exists) then
            if (present(optional_file)) then
                if (optional_file) return
            end if
            call fail(status, "cannot read " // path // ": no such file")
            return
        end if
        open (newunit=unit, file=path, status="old", action="read", iostat=ios, iomsg=message)
        if (ios /= 0) then
            call fail(status, "cannot read " // path // ": " // trim(message))
            return
        end if
        allocate (read_rows(0))
        line_number = 1
        read (unit, '(a)', iostat=ios) line
        if (ios /= 0 .or. trim(line) /= csv_header) then
            call bad_line("not the header of a bench CSV file")
            return
        end if
        do
            read (unit, '(a)', iostat=ios) line
            if (ios /= 0) exit
            line_number = line_number + 1
            ! Split at the commas; k ends as the number of fields found (at most 21).
            first = 1
            do k = 1, field_count
                comma = index(line(first:), ",")
                if (comma == 0) then
                    fields(k) = line(first:)
                    exit
                end if
                fields(k) = line(first:first + comma - 2)
                first = first + comma
            end do
            if (k /= field_count) then
                call bad_line("expected " // int_str(field_count) // " comma-separated fields")
                return
            end if
            row%system = fields(1)
            row%method = fields(2)
            row%precision = fields(3)
            if (.not. integer_field(4, 0, row%order_m)) return
            if (.not. integer_field(5, 0, row%order_n)) return
            if (.not. integer_field(6, 0, row%gauss_points)) return
            if (.not. integer_field(7, 0, row%order)) return
            if (.not. real_field(8, row%h, .true.)) return
            if (.not. integer_field(9, 0, row%steps)) return
            if (.not. real_field(10, row%error)) return
            if (.not. real_field(11, row%energy_error)) return
            if (.not. real_field(12, row%constraint_residual)) return
            if (.not. real_field(13, value)) return
            if (.not. seconds_ok(13, value)) return
            row%seconds = real(value, real64)
            if (.not. real_field(14, value)) return
            if (.not. seconds_ok(14, value)) return
            if (.not. count_field(15, row%newton_iterations)) return
            if (.not. count_field(16, row%residuals)) return
            if (.not. count_field(17, row%gradients)) return
            if (.not. count_field(18, row%hessians)) return
            if (.not. count_field(19, row%factorizations)) return
            if (.not. integer_field(20, -huge(1), row%code)) return
            if (status_code_name(row%code) == "unknown status") then
                call bad_line("field status is not a holosym status code: '" // &
                    trim(fields(20)) // "'")
                return
            end if
            if (.not. real_field(21, row%difference)) return
            if (index(row%method, variant_prefix) == 1 .and. step_variant(row%method) < 0) then
                call bad_line("method '" // trim(row%method) // "' is not " // variant_prefix &
                    // "0 .. " // variant_prefix // int_str(variant_count))
                return
            end if
            read_rows = [read_rows, row]
        end do
        close (unit)
        rows = [rows, read_rows]

    contains

        !> Field k as an integer >= lower, or fail naming it.
        logical function integer_field(k, lower, value) result(ok)
            integer, intent(in) :: k, lower
            integer, intent(out) :: value
            type(holosym_status_t) :: local
            call parse_integer(trim(field_names(k)), trim(fields(k)), value, local)
            ok = local%ok()
            if (ok) ok = value >= lower
            if (.not. ok) call bad_line("field " // trim(field_names(k)) // " is not " // &
                merge("an integer >= 0", "an integer     ", lower == 0) // ": '" // &
                trim(fields(k)) // "'")
        end function integer_field

        !> Field k as a count (an int64 >= 0), or fail naming it.
        logical function count_field(k, value) result(ok)
            integer, intent(in) :: k
            integer(int64), intent(out) :: value
            integer :: ios
            value = 0
            ok = len_trim(fields(k)) >= 1 .and. len_trim(fields(k)) <= 18 .and. &
                verify(trim(fields(k)), "0123456789") == 0
            if (ok) then
                read (fields(k), *, iostat=ios) value
                ok = ios == 0
            end if
            if (.not. ok) call bad_line("field " // trim(field_names(k)) // &
                " is not a count >= 0: '" // trim(fields(k)) // "'")
        end function count_field

        !> Field k as a finite real >= 0 (> 0 with `positive`), or fail naming it.
        logical function real_field(k, value, positive) result(ok)
            integer, intent(in) :: k
            real(wp), intent(out) :: value
            logical, intent(in), optional :: positive
            type(holosym_status_t) :: local
            logical :: strict
            strict = .false.
            if (present(positive)) strict = positive
            call parse_real(trim(field_names(k)), trim(fields(k)), value, local)
            ok = local%ok()
            if (ok) ok = value >= 0
            if (ok .and. strict) ok = value > 0
            if (.not. ok) call bad_line("field " // trim(field_names(k)) // " is not a " // &
                merge("number > 0 ", "number >= 0", strict) // ": '" // trim(fields(k)) // "'")
        end function real_field

        !> Seconds of field k at most `max_seconds`, or fail naming it.
        logical function seconds_ok(k, value) result(ok)
            integer, intent(in) :: k
            real(wp), intent(in) :: value
            ok = value <= max_seconds
            if (.not. ok) call bad_line("field " // trim(field_names(k)) // " is more than " &
                // "1e12 seconds: '" // trim(fields(k)) // "'")
        end function seconds_ok

        !> Fail naming the file and line; close the file.
        subroutine bad_line(reason)
            character(len=*), intent(in) :: reason !! what is wrong with the line
            call fail(status, path // ": line " // int_str(line_number) // ": " // reason)
            close (unit)
        end subroutine bad_line

    end subroutine read_bench_csv

    !> The option set k of a per-step row's method "variant-k", or -1 when the method is
    !! not one of variant-0 .. variant-<variant_count>.
    pure integer function step_variant(method)
        character(len=*), intent(in) :: method !! e.g. "variant-3"
        integer :: ios
        step_variant = -1
        if (index(method, variant_prefix) /= 1) return
        read (method(len(variant_prefix) + 1:), *, iostat=ios) step_variant
        if (ios /= 0 .or. step_variant < 0 .or. step_variant > variant_count) step_variant = -1
    end function step_variant

    !> Reference states: read "system,q or p,index,value" lines, or compute and write them
    !! (appended to DIR/reference.csv). A file to read must hold, for `system`, every index
    !! 1..n of q and of p exactly once with a finite value; lines of other systems and
    !! lines starting with '#' are skipped. Failure (HOLOSYM_INVALID_ARGUMENT) names the
    !! file, the line and what is wrong.
    subroutine reference_for(system, sys, q0, p0, options, q_ref, p_ref, err_unit, status)
        character(len=*), intent(in) :: system
        class(constrained_hamiltonian), intent(in) :: sys
        real(wp), intent(in) :: q0(:), p0(:)
        type(bench_options_t), intent(in) :: options
        real(wp), intent(out) :: q_ref(:), p_ref(:)
        integer, intent(in) :: err_unit
        type(holosym_status_t), intent(inout) :: status
        character(len=1024) :: line
        character(len=256) :: message
        character(len=:), allocatable :: fields(:)
        logical :: seen(size(q_ref), 2)
        integer :: unit, ios, index_value, k, system_index, line_number, kind
        real(wp) :: value, change
        type(holosym_status_t) :: local
        type(output_t) :: file
        if (len(options%reference) > 0) then
            open (newunit=unit, file=options%reference, status="old", action="read", &
                  iostat=ios, iomsg=message)
            if (ios /= 0) then
                call fail(status, "cannot read reference file " // options%reference // ": " &
                    // trim(message))
                return
            end if
            seen = .false.
            line_number = 0
            do
                read (unit, '(a)', iostat=ios) line
                if (ios /= 0) exit
                line_number = line_number + 1
                if (len_trim(line) == 0) cycle
                if (line(1:1) == "#") cycle
                call split_fields(trim(line), fields)
                if (size(fields) /= 4) then
                    call bad("expected 4 comma-separated fields: system,q|p,index,value")
                    return
                end if
                if (trim(fields(1)) /= system) cycle
                select case (trim(fields(2)))
                case ("q")
                    kind = 1
                case ("p")
                    kind = 2
                case default
                    call bad("the second field must be q or p; got '" // trim(fields(2)) // "'")
                    return
                end select
                call parse_integer("index", trim(fields(3)), index_value, local)
                if (.not. local%ok()) index_value = 0
                if (index_value < 1 .or. index_value > size(q_ref)) then
                    call bad("index must be in 1.." // int_str(size(q_ref)) // " for " // &
                        system // "; got '" // trim(fields(3)) // "'")
                    return
                end if
                if (seen(index_value, kind)) then
                    call bad(trim(fields(2)) // "(" // trim(fields(3)) // ") of " // system // &
                        " given twice")
                    return
                end if
                call parse_real("value", trim(fields(4)), value, local)
                if (.not. local%ok()) then
                    call bad("the value is not a finite number: '" // trim(fields(4)) // "'")
                    return
                end if
                seen(index_value, kind) = .true.
                if (kind == 1) q_ref(index_value) = value
                if (kind == 2) p_ref(index_value) = value
            end do
            close (unit)
            do kind = 1, 2
                do k = 1, size(q_ref)
                    if (.not. seen(k, kind)) then
                        call fail(status, "reference file " // options%reference // &
                            " lacks " // merge("q", "p", kind == 1) // "(" // int_str(k) // &
                            ") of system " // system)
                        return
                    end if
                end do
            end do
            return
        end if
        system_index = findloc(bench_systems, system, dim=1)
        call reference_state(sys, q0, p0, bench_span(system), reference_steps(system_index), &
                             q_ref, p_ref, change, status)
        if (.not. status%ok()) return
        write (err_unit, '(a)') "bench: reference for " // system // ": M = 8 (order 16), h = " &
            // real_str(reference_steps(system_index) / 2) // "; it differs from h = " // &
            real_str(reference_steps(system_index)) // " by " // real_str(change) // &
            ", so its own error is about " // real_str(change / (2.0_wp**16 - 1))
        ! Appended: the file holds the references of the systems run before this one.
        call read_text(options%out_dir // "/reference.csv", fields, status)
        if (.not. status%ok()) return
        call open_output(options%out_dir // "/reference.csv", file, status)
        if (.not. status%ok()) return
        do k = 1, size(fields)
            call file%line(trim(fields(k)))
        end do
        do k = 1, size(q_ref)
            call file%line(system // ",q," // int_str(k) // "," // csv_real(q_ref(k)))
        end do
        do k = 1, size(p_ref)
            call file%line(system // ",p," // int_str(k) // "," // csv_real(p_ref(k)))
        end do
        call file%line("# " // system // ": M = 8, h = " // &
            real_str(reference_steps(system_index)) // " and h/2 differ by " // &
            real_str(change) // "; estimated error of the h/2 run " // &
            real_str(change / (2.0_wp**16 - 1)))
        call file%close(status)

    contains

        !> Fail naming the reference file and the line.
        subroutine bad(reason)
            character(len=*), intent(in) :: reason
            call fail(status, options%reference // ": line " // int_str(line_number) // &
                ": " // reason)
            close (unit)
        end subroutine bad

    end subroutine reference_for

    !> The comma-separated fields of a line (blanks kept).
    pure subroutine split_fields(line, fields)
        character(len=*), intent(in) :: line
        character(len=:), allocatable, intent(out) :: fields(:)
        integer :: count, first, comma, k
        count = 1
        do k = 1, len(line)
            if (line(k:k) == ",") count = count + 1
        end do
        allocate (character(len=max(len(line), 1)) :: fields(count))
        first = 1
        do k = 1, count
            comma = index(line(first:), ",")
            if (comma == 0) then
                fields(k) = line(first:)
            else
                fields(k) = line(first:first + comma - 2)
                first = first + comma
            end if
        end do
    end subroutine split_fields

    !> The lines of a text file (none when it does not exist).
    subroutine read_text(path, lines, status)
        character(len=*), intent(in) :: path
        character(len=:), allocatable, intent(out) :: lines(:)
        type(holosym_status_t), intent(inout) :: status
        character(len=1024) :: line
        character(len=256) :: message
        character(len=1024), allocatable :: kept(:)
        integer :: unit, ios
        logical :: exists
        allocate (kept(0))
        inquire (file=path, exist=exists)
        if (exists) then
            open (newunit=unit, file=path, status="old", action="read", iostat=ios, &
                  iomsg=message)
            if (ios /= 0) then
                call fail(status, "cannot read " // path // ": " // trim(message))
                return
            end if
            do
                read (unit, '(a)', iostat=ios) line
                if (ios /= 0) exit
                kept = [character(len=1024) :: kept, line]
            end do
            close (unit)
        end if
        allocate (character(len=1024) :: lines(size(kept)))
        lines = kept
    end subroutine read_text

    !> Run the benchmark.
    subroutine run_bench(options, err_unit, rows, steps_rows, status)
        type(bench_options_t), intent(in) :: options
        integer, intent(in) :: err_unit
        type(bench_row_t), allocatable, intent(out) :: rows(:), steps_rows(:)
        type(holosym_status_t), intent(inout) :: status
        class(constrained_hamiltonian), allocatable :: sys
        real(wp), allocatable :: q0(:), p0(:), q_ref(:), p_ref(:), q_end(:), p_end(:)
        real(wp), allocatable :: q_plain(:), p_plain(:)
        type(bench_settings_t) :: settings
        type(bench_row_t) :: row
        type(holosym_status_t) :: run_status
        integer :: s, order_m, gauss_points, order, family, variant, config
        type(output_t) :: file
        character(len=11), parameter :: families(2) = [character(len=11) :: "triple-jump", &
                                                        "suzuki"]
        allocate (rows(0), steps_rows(0))
        settings%budget = options%budget
        settings%progress_unit = err_unit
        if (len(options%reference) == 0) then
            call open_output(options%out_dir // "/reference.csv", file, status)
            if (.not. status%ok()) return
            call file%line("# reference states q(T), p(T): system,q|p,index,value")
            call file%close(status)
            if (.not. status%ok()) return
        end if
        do s = 1, size(bench_systems)
            if (.not. selected(options%systems, bench_systems(s))) cycle
            call make_system(trim(bench_systems(s)), sys, q0, p0, status)
            if (.not. status%ok()) return
            allocate (q_ref(size(q0)), p_ref(size(p0)), q_end(size(q0)), p_end(size(p0)), &
                      q_plain(size(q0)), p_plain(size(p0)))
            call reference_for(trim(bench_systems(s)), sys, q0, p0, options, q_ref, p_ref, &
                               err_unit, status)
            if (.not. status%ok()) return
            if (options%per_step .and. bench_systems(s) == "pendulum") then
                do config = 1, size(per_step_configs, 2)
                    do variant = 0, variant_count
                        call holosym_run(sys, q0, p0, bench_span("pendulum"), &
                            per_step_configs(1, config), per_step_configs(2, config), &
                            per_step_configs(3, config), per_step_h, variant, q_ref, p_ref, &
                            .false., row, run_status, q_end, p_end)
                        if (variant == 0) then
                            q_plain = q_end
                            p_plain = p_end
                        end if
                        row%difference = max(maxval(abs(q_end - q_plain)), &
                                             maxval(abs(p_end - p_plain)))
                        row%system = "pendulum"
                        write (row%method, '(a, i0)') variant_prefix, variant
                        steps_rows = [steps_rows, row]
                        write (err_unit, '(a)') "bench: per step (" // &
                            int_str(row%order_m) // "," // int_str(row%order_n) // "," // &
                            int_str(row%gauss_points) // ") " // variant_name(variant) // ": " // &
                            real_str(real(row%seconds, wp) / row%steps) // " s"
                    end do
                end do
            end if
            do order_m = 1, options%max_m
                do gauss_points = order_m, order_m + 1
                    call sweep_holosym(sys, trim(bench_systems(s)), q0, p0, order_m, &
                        order_m - 1, gauss_points, sweep_h0, q_ref, p_ref, settings, rows)
                end do
            end do
            do family = 1, 2
                do order = 2, options%max_rattle_order, 2
                    if (order == 2 .and. family == 2) cycle  ! order 2 is plain RATTLE
                    call sweep_rattle(sys, trim(bench_systems(s)), q0, p0, order, &
                        trim(families(family)), sweep_h0, q_ref, p_ref, settings, rows)
                end do
            end do
            deallocate (q_ref, p_ref, q_end, p_end, q_plain, p_plain)
        end do
    end subroutine run_bench

    !> Cheapest successful row of a method family meeting an error target.
    pure integer function cheapest(rows, system, prefix, precision, target)
        type(bench_row_t), intent(in) :: rows(:)
        character(len=*), intent(in) :: system, prefix, precision
        real(wp), intent(in) :: target
        integer :: i
        cheapest = 0
        do i = 1, size(rows)
            if (trim(rows(i)%system) /= system .or. trim(rows(i)%precision) /= precision) cycle
            if (index(rows(i)%method, prefix) /= 1 .or. rows(i)%method == "holosym-plain") cycle
            if (rows(i)%code /= HOLOSYM_SUCCESS .or. .not. rows(i)%error <= target) cycle
            if (cheapest == 0) then
                cheapest = i
            else if (rows(i)%seconds < rows(cheapest)%seconds) then
                cheapest = i
            end if
        end do
    end function cheapest

    function seconds_text(seconds) result(text)
        real(real64), intent(in) :: seconds
        character(len=:), allocatable :: text
        character(len=16) :: buffer
        write (buffer, '(es9.2)') seconds
        text = trim(adjustl(buffer))
    end function seconds_text

    !> ratio_text(a / b), or "—" when b is 0 (a run too fast to time, no steps).
    function quotient_text(a, b) result(text)
        real(real64), intent(in) :: a, b
        character(len=:), allocatable :: text
        if (b > 0) then
            text = ratio_text(a / b)
        else
            text = "—"
        end if
    end function quotient_text

    function ratio_text(ratio) result(text)
        real(real64), intent(in) :: ratio
        character(len=:), allocatable :: text
        character(len=16) :: buffer
        write (buffer, '(f10.1)') ratio
        text = trim(adjustl(buffer))
    end function ratio_text

    !> Description of a row's configuration.
    function config_text(row) result(text)
        type(bench_row_t), intent(in) :: row
        character(len=:), allocatable :: text
        character(len=16) :: buffer
        if (row%h <= huge(1.0_real64)) then
            write (buffer, '(g0.4)') real(row%h, real64)
        else
            buffer = real_str(row%h)
        end if
        if (index(row%method, "holosym") == 1) then
            text = "(" // int_str(row%order_m) // "," // int_str(row%order_n) // "," // &
                int_str(row%gauss_points) // ") h=" // trim(buffer)
        else
            text = trim(row%method(8:)) // " p=" // int_str(row%order) // " h=" // trim(buffer)
        end if
    end function config_text

    !> The Markdown summary: per target and system the cheapest configuration of holosym
    !! and of RATTLE in holosym, with the competitor table's time and the ratios.
    subroutine write_summary(rows, steps_rows, out)
        type(bench_row_t), intent(in) :: rows(:)       !! sweep rows (any precision)
        type(bench_row_t), intent(in) :: steps_rows(:) !! per-step comparison rows
        type(output_t), intent(inout) :: out           !! where the Markdown goes
        integer :: t, s, best, rival, precision, c, variant, plain
        character(len=:), allocatable :: line, prec
        real(real64) :: table, per_step, plain_step
        real(wp) :: difference
        call out%line("# holosym work-precision benchmark")
        call out%line("")
        call out%line("Error = max(|q - q_ref|, |p - p_ref|) at T; CPU seconds on one " // &
            "core, median of 3 for runs under 0.2 s. holosym: all speed options (simplified " // &
            "Newton, mixed-precision LU, real64 pre-solve in the real128 build, exact " // &
            "Hessians, extrapolated guess). RATTLE: " // &
            "composed inside holosym (triple jump or Suzuki), same problem interface. " // &
            "'table' is the competitor's (GNI_COMP) time from the issue; 'x' = table / holosym.")
        do precision = 2, 1, -1
            prec = merge("real128", "real64 ", precision == 2)
            if (.not. any(rows%precision == prec)) cycle
            call out%line("")
            call out%line("## " // trim(prec))
            call out%line("")
            call out%line("| target | system | holosym config | holosym s | " // &
                "RATTLE in holosym | RATTLE s | table s | x table | x RATTLE |")
            call out%line("|---|---|---|---|---|---|---|---|---|")
            do t = 1, size(bench_targets)
                do s = 1, size(bench_systems)
                    if (.not. any(rows%system == bench_systems(s))) cycle
                    best = cheapest(rows, trim(bench_systems(s)), "holosym", trim(prec), &
                                    bench_targets(t))
                    rival = cheapest(rows, trim(bench_systems(s)), "rattle", trim(prec), &
                                     bench_targets(t))
                    table = -1
                    do c = 1, size(competitor_targets)
                        if (abs(real(bench_targets(t), real64) / competitor_targets(c) - 1) &
                            < 1.0e-6_real64) table = competitor_seconds(c, s, precision)
                    end do
                    line = "| " // trim(real_str(bench_targets(t))) // " | " // &
                        trim(bench_systems(s)) // " | "
                    if (best > 0) then
                        line = line // config_text(rows(best)) // " | " // &
                            seconds_text(rows(best)%seconds) // " | "
                    else
                        line = line // "— | — | "
                    end if
                    if (rival > 0) then
                        line = line // config_text(rows(rival)) // " | " // &
                            seconds_text(rows(rival)%seconds) // " | "
                    else
                        line = line // "— | — | "
                    end if
                    if (table > 0) then
                        line = line // seconds_text(table) // " | "
                    else
                        line = line // "— | "
                    end if
                    if (table > 0 .and. best > 0) then
                        line = line // quotient_text(table, rows(best)%seconds) // " | "
                    else
                        line = line // "— | "
                    end if
                    if (rival > 0 .and. best > 0) then
                        line = line // quotient_text(rows(rival)%seconds, &
                            rows(best)%seconds) // " |"
                    else
                        line = line // "— |"
                    end if
                    call out%line(line)
                end do
            end do
        end do
        if (size(steps_rows) == 0) return
        call out%line("")
        call out%line("## Per-step cost of the speed options (spherical pendulum, " // &
            "h = 1/8, T = 10)")
        call out%line("")
        call out%line("| (M,N,G) | option set | s / step | x plain | Newton it. / step" // &
            " | LU / step | gradients / step | max diff. from plain at T |")
        call out%line("|---|---|---|---|---|---|---|---|")
        plain = 0
        do c = 1, size(steps_rows)
            variant = step_variant(steps_rows(c)%method)
            if (variant < 0) cycle
            if (variant == 0) plain = c
            if (plain == 0) cycle
            per_step = steps_rows(c)%seconds / max(steps_rows(c)%steps, 1)
            plain_step = steps_rows(plain)%seconds / max(steps_rows(plain)%steps, 1)
            difference = steps_rows(c)%difference
            call out%line("| (" // int_str(steps_rows(c)%order_m) // "," // &
                int_str(steps_rows(c)%order_n) // "," // int_str(steps_rows(c)%gauss_points) &
                // ") " // trim(steps_rows(c)%precision) // " | " // variant_name(variant) // &
                " | " // seconds_text(per_step) // &
                " | " // quotient_text(plain_step, per_step) // " | " // &
                quotient_text(real(steps_rows(c)%newton_iterations, real64), &
                              real(steps_rows(c)%steps, real64)) // " | " // &
                quotient_text(real(steps_rows(c)%factorizations, real64), &
                              real(steps_rows(c)%steps, real64)) // " | " // &
                quotient_text(real(steps_rows(c)%gradients, real64), &
                              real(steps_rows(c)%steps, real64)) // " | " // &
                trim(real_str(difference)) // " |")
        end do
    end subroutine write_summary

    !> `holosym bench [options]`. Exit 0 success, 1 failure, 2 usage.
    subroutine bench_command(args, out, err_unit, exit_code)
        type(cli_argument_t), intent(in) :: args(:) !! the command's arguments
        type(output_t), intent(inout) :: out !! Markdown summary
        integer, intent(in) :: err_unit   !! progress and errors
        integer, intent(out) :: exit_code !! process exit code
        type(bench_options_t) :: options
        type(holosym_status_t) :: status
        type(bench_row_t), allocatable :: rows(:), steps_rows(:), all_rows(:)
        character(len=:), allocatable :: dir, csv_name
        type(output_t) :: file

        call parse_bench_options(args, options, status)
        if (.not. parsed_command_proceeds("bench", status, options%help, bench_help(), &
                                          out, err_unit, exit_code)) return
        if (len(options%summarize) > 0) then
            dir = options%summarize
        else
            dir = options%out_dir
            call make_directories(dir, status)
            if (status%ok()) call run_bench(options, err_unit, rows, steps_rows, status)
            csv_name = merge("bench64.csv", "bench.csv  ", wp_is_double)
            if (status%ok()) then
                call write_bench_csv(dir // "/" // trim(csv_name), rows, status)
                if (status%ok() .and. size(steps_rows) > 0) call write_bench_csv(dir // &
                    "/" // merge("steps64.csv", "steps.csv  ", wp_is_double), steps_rows, &
                    status)
            end if
        end if
        allocate (all_rows(0))
        if (allocated(steps_rows)) deallocate (steps_rows)
        allocate (steps_rows(0))
        if (status%ok()) call read_bench_csv(dir // "/bench.csv", all_rows, status, .true.)
        if (status%ok()) call read_bench_csv(dir // "/bench64.csv", all_rows, status, .true.)
        if (status%ok()) call read_bench_csv(dir // "/steps.csv", steps_rows, status, .true.)
        if (status%ok()) call read_bench_csv(dir // "/steps64.csv", steps_rows, status, .true.)
        if (status%ok() .and. size(all_rows) + size(steps_rows) == 0) call fail(status, &
            "no bench.csv, bench64.csv, steps.csv or steps64.csv in " // dir)
        if (status%ok()) call write_summary(all_rows, steps_rows, out)
        if (status%ok()) call open_output(dir // "/summary.md", file, status)
        if (status%ok()) then
            call write_summary(all_rows, steps_rows, file)
            call file%close(status)
        end if
        if (.not. status%ok()) then
            write (err_unit, '(a)') "holosym bench: " // status%message
            exit_code = EXIT_FAILURE
            return
        end if
        exit_code = EXIT_OK
    end subroutine bench_command

end module holosym_cli_bench

!> Holds `not_installed`: fpm installs no module of a source with a submodule.
submodule (holosym_cli_bench) holosym_cli_bench_app
    implicit none
contains
    module procedure not_installed
    end procedure not_installed
end submodule holosym_cli_bench_app
