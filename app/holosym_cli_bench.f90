!> The `bench` command: work-precision benchmark of holosym against RATTLE compositions
!! (inside holosym) and heyoka (measured in the same run by tools/heyoka_bench.py when
!! --heyoka names a Python that has it), the per-step cost of the speed options against
!! the plain path, the chain scaling study (--scaling) and the long runs (--long).
!!
!! Writes DIR/bench.csv (bench64.csv in the real64 build), DIR/heyoka.csv (heyoka64.csv),
!! DIR/steps.csv (per-step comparison), DIR/reference.csv (real128 build: initial and
!! reference states) and DIR/summary.md; the summary also goes to the output unit.
!! `--summarize DIR` only rebuilds DIR/summary.md and DIR/performance.md from the CSV
!! files there. tools/plot_bench.py draws the plots from the CSV files.
!!
!! Every file is written through `output_t` (a full disk fails the command), directories
!! are made with mkdir(2), and the children (heyoka's Python, the scaling points) run
!! without a shell, so no path or option reaches one. heyoka's rows come back through a
!! scratch file that is read as strictly as `--summarize` reads: the CSV files and the
!! `--reference` file are checked field by field (`read_bench_csv`, `reference_for`).
module holosym_cli_bench
    use, intrinsic :: iso_fortran_env, only: real64, int64
    use holosym_kinds, only: wp, wp_is_double
    use holosym_status_codes, only: holosym_status_t, int_str, real_str, &
        scientific_field => real_field, status_code_name, HOLOSYM_SUCCESS
    use holosym_problem, only: constrained_hamiltonian
    use holosym_benchmark, only: bench_row_t, bench_settings_t, reference_state, holosym_run, &
        sweep_holosym, sweep_rattle, variant_name, bench_span, bench_targets, variant_count, &
        rattle_families, rattle_orders, target_in_precision, accuracy_run
    use holosym_cli_common, only: parsed_command_proceeds, &
        cli_argument_t, split_option, option_value, parse_integer, parse_integer_in, &
        parse_real, fail, csv_real, csv_integer, join_lines, EXIT_OK, EXIT_FAILURE
    use holosym_systems, only: make_system, system_choices, max_links
    use holosym_output, only: output_t, open_output, make_directories, remove_file, &
        run_program, command_text, text_t, read_text_file, append_text, write_lines
    use holosym_bench_accuracy, only: run_accuracy
    use holosym_bench_scaling, only: scaling_point, scaling_links, scaling_header, &
        general_links_limit
    use holosym_bench_long, only: run_long
    use holosym_bench_report, only: scaling_section, long_section, models_section, &
        check_report_files
    use holosym_bench_models, only: run_models
    use holosym_study_text, only: int64_str, ratio_text
    implicit none
    private

    public :: bench_options_t, parse_bench_options, bench_command, bench_help, &
              read_bench_csv, write_bench_csv, write_summary

    !> Systems of the benchmark.
    character(len=*), parameter :: bench_systems(3) = [character(len=8) :: &
        "pendulum", "linkage", "planar"]
    !> Step of the reference pair (h and h/2) per system.
    real(wp), parameter :: reference_steps(3) = [0.0625_wp, 0.0625_wp, 0.0625_wp]
    !> Per-step comparison: spherical pendulum, h = 1/8, T = 10, at (2,1,3) and (7,6,8).
    real(wp), parameter :: per_step_h = 0.125_wp
    integer, parameter :: per_step_configs(3, 2) = reshape([2, 1, 3, 7, 6, 8], [3, 2])
    !> Largest --budget, in CPU seconds per run.
    real(wp), parameter :: max_budget = 3600
    !> Largest time of a run read back from a CSV file (a bound that keeps ratios finite).
    real(wp), parameter :: max_seconds = 1.0e12_wp
    !> A reference file's start q0, p0 must be the system's within this many epsilon
    !! (relative to max(1, |value|)): the real64 build reads the real128 file's digits.
    real(wp), parameter :: start_tolerance = 1024
    !> Largest step of the sweeps.
    real(wp), parameter :: sweep_h0 = 1
    !> Method of a per-step row: this prefix and the option set 0 .. variant_count.
    character(len=*), parameter :: variant_prefix = "variant-"
    !> CSV header of bench rows.
    character(len=*), parameter :: csv_header = "system,method,precision,M,N,G,order,h," // &
        "steps,error,energy_error,constraint_residual,seconds,seconds_per_step," // &
        "newton_iterations,residual_evaluations,gradient_evaluations,hessian_evaluations," // &
        "lu_factorizations,status,difference_from_plain,tolerance,compile_seconds"
    !> The competitor's script (run with the Python given by --heyoka), from the
    !! directory `make bench` runs in.
    character(len=*), parameter :: heyoka_script = "tools/heyoka_bench.py"

    !> A run through --accuracy (`chosen`, a row index) for a (target, system) pair, and
    !! heyoka's cheapest run reaching the target (`taylor`; 0: none).
    type :: accuracy_match_t
        real(wp) :: target = 0
        character(len=8) :: system = ""
        integer :: chosen = 0, taylor = 0
    end type accuracy_match_t

    !> Options of `holosym bench`.
    type :: bench_options_t
        character(len=:), allocatable :: out_dir     !! output directory
        character(len=:), allocatable :: reference   !! reference file to read ("" = compute)
        character(len=:), allocatable :: summarize   !! only summarize this directory
        character(len=:), allocatable :: systems     !! comma list (default all three)
        character(len=:), allocatable :: heyoka      !! Python with heyoka ("" = no heyoka)
        integer :: max_m = 8                         !! largest M
        integer :: max_rattle_order = 10             !! largest composition order
        real(real64) :: budget = 1.5_real64          !! CPU seconds per run before stopping
        logical :: quick = .false.                   !! M <= 4, order <= 6, budget 0.2 s
        logical :: per_step = .true.                 !! run the per-step comparison
        logical :: scaling = .false.                 !! the chain scaling study instead
        logical :: long = .false.                    !! the long runs instead
        logical :: models = .false.                  !! model files against built-ins instead
        logical :: accuracy = .false.                !! what --accuracy delivers, instead
        character(len=:), allocatable :: models_section !! only print this DIR's model section
        character(len=:), allocatable :: long_section !! only print this DIR's long-run section
        integer :: scaling_point = 0                 !! one chain of K links (internal)
        logical :: general = .false.                 !! with --scaling-point: general path
        logical :: help = .false.                    !! --help given
    end type bench_options_t

    interface
        !> Does nothing. Its body, in the submodule at the end of this file, keeps this
        !! application module out of `fpm install` (see fpm.toml).
        module subroutine not_installed()
        end subroutine not_installed
    end interface

    !> Newton tolerances of the extra real128 sweeps of holosym (M = 2..8, G = M + 1):
    !! 1e-12 is met by the real64 iterations alone (no real128 residual), the others stop
    !! the real128 iterations early.
    real(wp), parameter :: loose_tolerances(3) = [1.0e-12_wp, 1.0e-18_wp, 1.0e-24_wp]

contains

    !> The text of `holosym bench --help`.
    pure function bench_help() result(text)
        character(len=:), allocatable :: text !! the help
        text = join_lines([character(len=96) :: &
            "Usage: holosym bench [options]", &
            "", &
            "Work-precision benchmark: holosym (M = 1..8, N = M-1, G = M and M+1, fast options)", &
            "against RATTLE composed to orders 2-10 inside holosym (GNI_COMP's compositions)", &
            "and heyoka (with --heyoka), on the spherical pendulum (T = 10), spring-linkage", &
            "(T = 10), planar pendulum (T = 100); the per-step cost of each speed option", &
            "against the plain path.", &
            "", &
            "Options:", &
            "  --out DIR        output directory (default build/bench)", &
            "  --systems LIST   comma list of pendulum, linkage, planar (default all)", &
            "  --Mmax M         largest M (default 8)", &
            "  --order P        largest RATTLE composition order (default 10)", &
            "  --budget S       stop refining h once a run takes S CPU seconds (default 1.5)", &
            "  --quick          M <= 4, orders <= 6, budget 0.2 s, short heyoka sweep", &
            "  --heyoka PYTHON  also run tools/heyoka_bench.py with this Python (which has", &
            "                   the heyoka package), in this run, on the same reference", &
            "  --scaling        instead: chain of K pendula, K = 1..256, (4,3,5), h = 0.01:", &
            "                   cost per step, peak memory, reduced and general paths", &
            "                   (DIR/scaling.csv, scaling64.csv in the real64 build)", &
            "  --scaling-point K  one point of --scaling (K = 1..100000): its CSV line", &
            "                   (--general: the general path)", &
            "  --long           instead: long runs (planar T = 1e4, 1e5, spherical 1e4) to", &
            "                   errors 1e-20 and 1e-24 (DIR/long.csv; about 80 minutes;", &
            "                   --quick: T = 20 and 10)", &
            "  --models         instead: model files against the built-in models (pendulum,", &
            "                   linkage, chain of 64; DIR/models.csv) and chains of K = 8 ..", &
            "                   256 from model files in DIR/models/ (DIR/model_scaling.csv;", &
            "                   64.csv files in the real64 build; make bench-models)", &
            "  --models-section DIR  print the model-file section of DIR/performance.md", &
            "  --long-section DIR  print the long-run section of DIR/performance.md", &
            "  --accuracy       instead: what --accuracy delivers on the pendulum, linkage,", &
            "                   planar, double and magnetic systems to T = 10, requests", &
            "                   1e-8 .. 1e-30 (real64 1e-6 .. 1e-12): plan, estimate, error", &
            "                   reached, seconds (DIR/accuracy.csv, accuracy.md; 64 in the", &
            "                   real64 build; make bench-accuracy)", &
            "  --no-per-step    skip the per-step comparison", &
            "  --reference FILE read the reference states (the real64 build uses the", &
            "                   real128 one)", &
            "  --summarize DIR  only rebuild DIR/summary.md and DIR/performance.md from the", &
            "                   CSV files in DIR", &
            "  --help           this text", &
            "", &
            "Files: DIR/bench.csv (bench64.csv in the real64 build), DIR/heyoka.csv", &
            "(heyoka64.csv), DIR/steps.csv, DIR/reference.csv, DIR/summary.md,", &
            "DIR/performance.md. Plots: python3 tools/plot_bench.py DIR."])
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
        options%heyoka = ""
        options%models_section = ""
        options%long_section = ""
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
            case ("--scaling")
                options%scaling = .true.
            case ("--long")
                options%long = .true.
            case ("--models")
                options%models = .true.
            case ("--accuracy")
                options%accuracy = .true.
            case ("--general")
                options%general = .true.
            case ("--out", "--systems", "--Mmax", "--order", "--budget", "--reference", &
                  "--summarize", "--heyoka", "--scaling-point", "--models-section", &
                  "--long-section")
                call option_value(args, i, name, inline, has_inline, value, status)
                if (.not. status%ok()) return
                select case (name)
                case ("--out")
                    options%out_dir = value
                case ("--reference")
                    options%reference = value
                case ("--summarize")
                    options%summarize = value
                case ("--models-section")
                    options%models_section = value
                case ("--long-section")
                    options%long_section = value
                case ("--heyoka")
                    options%heyoka = value
                case ("--scaling-point")
                    call parse_integer_in(name, value, 1, max_links, options%scaling_point, &
                                          status)
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
            csv_real(row%difference) // "," // csv_real(row%tolerance) // "," // &
            csv_real(real(row%compile_seconds, wp))
    end function csv_line

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

    !> Read rows written by `write_bench_csv` (or by tools/heyoka_bench.py) and append them
    !! to `rows`. A missing file gives no rows and no error when `optional_file`. Failure
    !! (HOLOSYM_INVALID_ARGUMENT: an unreadable file or one that is not text, no bench
    !! header, a line without 23 fields, a field that is not a number or out of its range)
    !! names the file, the line and the field; `rows` is then unchanged. Ranges: system
    !! one of the benchmark's, precision real128 or real64, method holosym, holosym-plain,
    !! holosym-accuracy, rattle-<family>, heyoka or variant-0 .. variant-9; finite reals
    !! (no NaN or Inf, no magnitude beyond the working precision); h > 0; M, N, G, order,
    !! steps, the errors, the work counts and the difference >= 0; seconds, seconds per
    !! step and compile seconds in [0, 1e12]; tolerance in [0, 1); status a documented
    !! code.
    subroutine read_bench_csv(path, rows, status, optional_file)
        character(len=*), intent(in) :: path !! CSV file
        type(bench_row_t), allocatable, intent(inout) :: rows(:) !! rows are appended
        type(holosym_status_t), intent(inout) :: status !! I/O or format failure
        logical, intent(in), optional :: optional_file !! a missing file is not an error
        integer, parameter :: field_count = 23
        character(len=*), parameter :: field_names(field_count) = [character(len=21) :: &
            "system", "method", "precision", "M", "N", "G", "order", "h", "steps", "error", &
            "energy_error", "constraint_residual", "seconds", "seconds_per_step", &
            "newton_iterations", "residual_evaluations", "gradient_evaluations", &
            "hessian_evaluations", "lu_factorizations", "status", "difference_from_plain", &
            "tolerance", "compile_seconds"]
        type(text_t), allocatable :: lines(:), fields(:)
        type(bench_row_t), allocatable :: read_rows(:)
        type(bench_row_t) :: row
        type(holosym_status_t) :: local
        real(wp) :: value
        integer :: line_number, count
        logical :: exists
        inquire (file=path, exist=exists)
        if (.not. exists) then
            if (present(optional_file)) then
                if (optional_file) return
            end if
            call fail(status, "cannot read " // path // ": no such file")
            return
        end if
        call read_text_file(path, lines, local)
        if (.not. local%ok()) then
            call fail(status, local%message)
            return
        end if
        allocate (read_rows(size(lines)))
        count = 0
        line_number = 1
        if (size(lines) == 0) then
            call bad_line("not the header of a bench CSV file")
            return
        end if
        if (lines(1)%text /= csv_header) then
            call bad_line("not the header of a bench CSV file")
            return
        end if
        do line_number = 2, size(lines)
            call split_fields(lines(line_number)%text, fields)
            if (size(fields) /= field_count) then
                call bad_line("expected " // int_str(field_count) // &
                    " comma-separated fields; got " // int_str(size(fields)))
                return
            end if
            row = bench_row_t()
            if (.not. name_field(1, row%system)) return
            if (.not. name_field(2, row%method)) return
            if (.not. name_field(3, row%precision)) return
            if (.not. any(bench_systems == fields(1)%text)) then
                call bad_line("field system is not one of pendulum, linkage, planar: '" // &
                    fields(1)%text // "'")
                return
            end if
            if (.not. known_method(fields(2)%text)) then
                call bad_line("method '" // fields(2)%text // "' is not holosym, " // &
                    "holosym-plain, rattle-<family>, heyoka or " // variant_prefix // "0 .. " &
                    // variant_prefix // int_str(variant_count))
                return
            end if
            if (fields(3)%text /= "real128" .and. fields(3)%text /= "real64") then
                call bad_line("field precision is not real128 or real64: '" // &
                    fields(3)%text // "'")
                return
            end if
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
                    fields(20)%text // "'")
                return
            end if
            if (.not. real_field(21, row%difference)) return
            if (.not. real_field(22, row%tolerance)) return
            if (.not. row%tolerance < 1) then
                call bad_line("field tolerance is not in [0, 1): '" // fields(22)%text // "'")
                return
            end if
            if (.not. real_field(23, value)) return
            if (.not. seconds_ok(23, value)) return
            row%compile_seconds = real(value, real64)
            count = count + 1
            read_rows(count) = row
        end do
        rows = [rows, read_rows(:count)]

    contains

        !> Field k into a text field of the row, or fail when it is empty or too long.
        logical function name_field(k, value) result(ok)
            integer, intent(in) :: k
            character(len=*), intent(out) :: value
            ok = len(fields(k)%text) >= 1 .and. len(fields(k)%text) <= len(value)
            value = ""
            if (ok) then
                value = fields(k)%text
            else
                call bad_line("field " // trim(field_names(k)) // " is empty or longer " // &
                    "than " // int_str(len(value)) // " characters")
            end if
        end function name_field

        !> Field k as an integer >= lower, or fail naming it.
        logical function integer_field(k, lower, value) result(ok)
            integer, intent(in) :: k, lower
            integer, intent(out) :: value
            call parse_integer(trim(field_names(k)), fields(k)%text, value, local)
            ok = local%ok()
            if (ok) ok = value >= lower
            if (.not. ok) call bad_line("field " // trim(field_names(k)) // " is not " // &
                merge("an integer >= 0", "an integer     ", lower == 0) // ": '" // &
                fields(k)%text // "'")
        end function integer_field

        !> Field k as a count (an int64 >= 0), or fail naming it.
        logical function count_field(k, value) result(ok)
            integer, intent(in) :: k
            integer(int64), intent(out) :: value
            integer :: ios
            value = 0
            ok = len(fields(k)%text) >= 1 .and. len(fields(k)%text) <= 18
            if (ok) ok = verify(fields(k)%text, "0123456789") == 0
            if (ok) then
                read (fields(k)%text, *, iostat=ios) value
                ok = ios == 0
            end if
            if (.not. ok) call bad_line("field " // trim(field_names(k)) // &
                " is not a count >= 0: '" // fields(k)%text // "'")
        end function count_field

        !> Field k as a finite real >= 0 (> 0 with `positive`), or fail naming it.
        logical function real_field(k, value, positive) result(ok)
            integer, intent(in) :: k
            real(wp), intent(out) :: value
            logical, intent(in), optional :: positive
            logical :: strict
            strict = .false.
            if (present(positive)) strict = positive
            call parse_real(trim(field_names(k)), fields(k)%text, value, local)
            ok = local%ok()
            if (ok) ok = value >= 0
            if (ok .and. strict) ok = value > 0
            if (.not. ok) call bad_line("field " // trim(field_names(k)) // " is not a " // &
                merge("number > 0 ", "number >= 0", strict) // ": '" // fields(k)%text // "'")
        end function real_field

        !> Seconds of field k at most `max_seconds`, or fail naming it.
        logical function seconds_ok(k, value) result(ok)
            integer, intent(in) :: k
            real(wp), intent(in) :: value
            ok = value <= max_seconds
            if (.not. ok) call bad_line("field " // trim(field_names(k)) // " is more than " &
                // "1e12 seconds: '" // fields(k)%text // "'")
        end function seconds_ok

        !> Fail naming the file and line.
        subroutine bad_line(reason)
            character(len=*), intent(in) :: reason !! what is wrong with the line
            call fail(status, path // ": line " // int_str(line_number) // ": " // reason)
        end subroutine bad_line

    end subroutine read_bench_csv

    !> Whether `method` is one a bench CSV file may hold: holosym, holosym-plain,
    !! holosym-accuracy, heyoka,
    !! rattle-<one of the composition families>, or a per-step option set variant-k.
    pure logical function known_method(method)
        character(len=*), intent(in) :: method
        integer :: family
        known_method = method == "holosym" .or. method == "holosym-plain" .or. &
            method == "holosym-accuracy" .or. method == "heyoka" .or. step_variant(method) >= 0
        do family = 1, size(rattle_families)
            if (method == "rattle-" // trim(rattle_families(family))) known_method = .true.
        end do
    end function known_method

    !> The comma-separated fields of a line, each as given (blanks kept).
    pure subroutine split_fields(line, fields)
        character(len=*), intent(in) :: line
        type(text_t), allocatable, intent(out) :: fields(:)
        integer :: count, first, comma, k
        count = 1
        do k = 1, len(line)
            if (line(k:k) == ",") count = count + 1
        end do
        allocate (fields(count))
        first = 1
        do k = 1, count
            comma = index(line(first:), ",")
            if (comma == 0) then
                fields(k)%text = line(first:)
            else
                fields(k)%text = line(first:first + comma - 2)
                first = first + comma
            end if
        end do
    end subroutine split_fields

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

    !> Reference states of `system`: read from the --reference file, or computed (M = 8 at
    !! h and h/2) and written to DIR/reference.csv with the start (the lines of the
    !! systems run before are kept in `written`).
    !!
    !! A file to read has lines `system,kind,index,value` (blank lines and lines starting
    !! with '#' are skipped; every other line has exactly these 4 fields). For `system`:
    !! kind is q, p (the state at T) or q0, p0 (the start); the index is in 1..n; each
    !! (kind, index) appears at most once, with a finite value; every index of q and of p
    !! must be there. q0 and p0 are optional as a pair: absent, or both complete, and then
    !! equal to the system's own start (within `start_tolerance` epsilon: a reference of
    !! another start would make every error meaningless); with --heyoka they are required
    !! (heyoka starts from them). Lines of other systems are not read further. Failure
    !! (HOLOSYM_INVALID_ARGUMENT) names the file, the line and what is wrong.
    subroutine reference_for(system, sys, q0, p0, options, q_ref, p_ref, written, err_unit, &
                             status)
        character(len=*), intent(in) :: system
        class(constrained_hamiltonian), intent(in) :: sys
        real(wp), intent(in) :: q0(:), p0(:)
        type(bench_options_t), intent(in) :: options
        real(wp), intent(out) :: q_ref(:), p_ref(:)
        type(text_t), allocatable, intent(inout) :: written(:) !! lines of DIR/reference.csv
        integer, intent(in) :: err_unit
        type(holosym_status_t), intent(inout) :: status
        character(len=*), parameter :: kinds(4) = [character(len=2) :: "q", "p", "q0", "p0"]
        type(text_t), allocatable :: lines(:), fields(:)
        logical :: seen(size(q_ref), 4)
        real(wp) :: values(size(q_ref), 4)
        integer :: index_value, k, system_index, line_number, kind
        real(wp) :: value, change
        type(holosym_status_t) :: local
        if (len(options%reference) > 0) then
            call read_text_file(options%reference, lines, local)
            if (.not. local%ok()) then
                call fail(status, "cannot read reference file: " // local%message)
                return
            end if
            seen = .false.
            values = 0
            do line_number = 1, size(lines)
                if (len_trim(lines(line_number)%text) == 0) cycle
                if (lines(line_number)%text(1:1) == "#") cycle
                call split_fields(lines(line_number)%text, fields)
                if (size(fields) /= 4) then
                    call bad("expected 4 comma-separated fields: system,q0|p0|q|p,index,value")
                    return
                end if
                if (fields(1)%text /= system) cycle
                kind = position_of(kinds, fields(2)%text)
                if (kind == 0) then
                    call bad("the second field must be q0, p0, q or p; got '" // &
                        fields(2)%text // "'")
                    return
                end if
                call parse_integer("index", fields(3)%text, index_value, local)
                if (.not. local%ok()) index_value = 0
                if (index_value < 1 .or. index_value > size(q_ref)) then
                    call bad("index must be in 1.." // int_str(size(q_ref)) // " for " // &
                        system // "; got '" // fields(3)%text // "'")
                    return
                end if
                if (seen(index_value, kind)) then
                    call bad(fields(2)%text // "(" // fields(3)%text // ") of " // system // &
                        " given twice")
                    return
                end if
                call parse_real("value", fields(4)%text, value, local)
                if (.not. local%ok()) then
                    call bad("the value is not a finite number: '" // fields(4)%text // "'")
                    return
                end if
                if (kind >= 3) then
                    associate (start => merge(q0(index_value), p0(index_value), kind == 3))
                        if (.not. abs(value - start) <= start_tolerance * epsilon(1.0_wp) * &
                            max(1.0_wp, abs(start))) then
                            call bad(fields(2)%text // "(" // fields(3)%text // ") of " // &
                                system // " is " // fields(4)%text // ", but the system " // &
                                "starts at " // trim(real_str(start)) // ": a reference " // &
                                "of another start")
                            return
                        end if
                    end associate
                end if
                seen(index_value, kind) = .true.
                values(index_value, kind) = value
            end do
            do kind = 1, 4
                if (kind >= 3 .and. .not. (any(seen(:, 3:4)) .or. len(options%heyoka) > 0)) &
                    exit
                do k = 1, size(q_ref)
                    if (.not. seen(k, kind)) then
                        call fail(status, "reference file " // options%reference // &
                            " lacks " // trim(kinds(kind)) // "(" // int_str(k) // &
                            ") of system " // system)
                        if (kind >= 3 .and. .not. any(seen(:, 3:4))) status%message = &
                            status%message // " (--heyoka starts from q0, p0)"
                        return
                    end if
                end do
            end do
            q_ref = values(:, 1)
            p_ref = values(:, 2)
            return
        end if
        system_index = position_of(bench_systems, system)
        write (err_unit, '(a)') "bench: reference for " // system // ": computing M = 8 " // &
            "(order 16) with h = " // real_str(reference_steps(system_index)) // " and h/2"
        flush (err_unit)
        call reference_state(sys, q0, p0, bench_span(system), reference_steps(system_index), &
                             q_ref, p_ref, change, status)
        if (.not. status%ok()) return
        write (err_unit, '(a)') "bench: reference for " // system // ": M = 8 (order 16), h = " &
            // real_str(reference_steps(system_index) / 2) // "; it differs from h = " // &
            real_str(reference_steps(system_index)) // " by " // real_str(change) // &
            ", so its own error is about " // real_str(change / (2.0_wp**16 - 1))
        do k = 1, size(q0)
            call add(system // ",q0," // int_str(k) // "," // csv_real(q0(k)))
        end do
        do k = 1, size(p0)
            call add(system // ",p0," // int_str(k) // "," // csv_real(p0(k)))
        end do
        do k = 1, size(q_ref)
            call add(system // ",q," // int_str(k) // "," // csv_real(q_ref(k)))
        end do
        do k = 1, size(p_ref)
            call add(system // ",p," // int_str(k) // "," // csv_real(p_ref(k)))
        end do
        call add("# " // system // ": M = 8, h = " // real_str(reference_steps(system_index)) &
            // " and h/2 differ by " // real_str(change) // "; estimated error of the h/2 " &
            // "run " // real_str(change / (2.0_wp**16 - 1)))
        call write_lines(options%out_dir // "/reference.csv", written, status)

    contains

        !> Fail naming the reference file and the line.
        subroutine bad(reason)
            character(len=*), intent(in) :: reason
            call fail(status, options%reference // ": line " // int_str(line_number) // &
                ": " // reason)
        end subroutine bad

        subroutine add(line)
            character(len=*), intent(in) :: line
            call append_text(written, line)
        end subroutine add

    end subroutine reference_for

    !> The index of `name` in `names` (trailing blanks ignored), 0 if absent.
    pure integer function position_of(names, name) result(position)
        character(len=*), intent(in) :: names(:), name
        integer :: k
        position = 0
        do k = 1, size(names)
            if (names(k) == name) then
                position = k
                return
            end if
        end do
    end function position_of

    !> Run the benchmark.
    subroutine run_bench(options, err_unit, rows, steps_rows, status)
        type(bench_options_t), intent(in) :: options
        integer, intent(in) :: err_unit
        type(bench_row_t), allocatable, intent(out) :: rows(:), steps_rows(:)
        type(holosym_status_t), intent(inout) :: status
        class(constrained_hamiltonian), allocatable :: sys
        real(wp), allocatable :: q0(:), p0(:), q_ref(:), p_ref(:), q_end(:), p_end(:)
        real(wp), allocatable :: q_plain(:), p_plain(:)
        type(bench_settings_t) :: settings, loose
        type(bench_row_t) :: row
        type(bench_row_t), allocatable :: heyoka_rows(:)
        type(holosym_status_t) :: run_status
        type(text_t), allocatable :: reference_lines(:)
        integer :: tolerance
        integer :: s, order_m, gauss_points, family, variant, config
        character(len=:), allocatable :: heyoka_csv
        allocate (rows(0), steps_rows(0), heyoka_rows(0))
        heyoka_csv = options%out_dir // "/" // trim(merge("heyoka64.csv", "heyoka.csv  ", &
                                                          wp_is_double))
        ! The rows of an earlier run must not pass for this run's.
        if (len(options%heyoka) > 0) call remove_file(heyoka_csv, status)
        if (.not. status%ok()) return
        settings%budget = options%budget
        settings%progress_unit = err_unit
        settings%sweeps = sweep_count(options)
        settings%sweep = 0
        call settings%clock%begin()
        allocate (reference_lines(0))
        if (len(options%reference) == 0) then
            call append_text(reference_lines, "# initial states q0, p0 and reference " // &
                "states q(T), p(T): system,q0|p0|q|p,index,value")
            call write_lines(options%out_dir // "/reference.csv", reference_lines, status)
            if (.not. status%ok()) return
        end if
        do s = 1, size(bench_systems)
            if (.not. selected(options%systems, bench_systems(s))) cycle
            call make_system(trim(bench_systems(s)), sys, q0, p0, status)
            if (.not. status%ok()) return
            allocate (q_ref(size(q0)), p_ref(size(p0)), q_end(size(q0)), p_end(size(p0)), &
                      q_plain(size(q0)), p_plain(size(p0)))
            call reference_for(trim(bench_systems(s)), sys, q0, p0, options, q_ref, p_ref, &
                               reference_lines, err_unit, status)
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
                    settings%sweep = settings%sweep + 1
                    call sweep_holosym(sys, trim(bench_systems(s)), q0, p0, order_m, &
                        order_m - 1, gauss_points, sweep_h0, q_ref, p_ref, settings, rows)
                end do
            end do
            ! Looser Newton tolerances buy speed where the target is far above round-off.
            do tolerance = 1, size(loose_tolerances)
                if (wp_is_double) exit
                loose = settings
                loose%newton_tolerance = loose_tolerances(tolerance)
                do order_m = 2, min(8, options%max_m)
                    settings%sweep = settings%sweep + 1
                    loose%sweep = settings%sweep
                    call sweep_holosym(sys, trim(bench_systems(s)), q0, p0, order_m, &
                        order_m - 1, order_m + 1, sweep_h0, q_ref, p_ref, loose, rows)
                end do
            end do
            call accuracy_rows(sys, trim(bench_systems(s)), q0, p0, q_ref, p_ref, err_unit, rows)
            do family = 1, size(rattle_families)
                if (rattle_orders(family) > options%max_rattle_order) cycle
                settings%sweep = settings%sweep + 1
                call sweep_rattle(sys, trim(bench_systems(s)), q0, p0, rattle_orders(family), &
                    trim(rattle_families(family)), sweep_h0, q_ref, p_ref, settings, rows)
            end do
            if (len(options%heyoka) > 0) then
                call heyoka_sweep(options, trim(bench_systems(s)), heyoka_csv, err_unit, &
                                  heyoka_rows, status)
                if (.not. status%ok()) return
            end if
            deallocate (q_ref, p_ref, q_end, p_end, q_plain, p_plain)
        end do
    end subroutine run_bench

    !> The runs through `--accuracy` of one system: one per error target of this build's
    !! table, each as `holosym simulate --accuracy TARGET --T T` makes it (pilot, then run).
    subroutine accuracy_rows(sys, system, q0, p0, q_ref, p_ref, err_unit, rows)
        class(constrained_hamiltonian), intent(in) :: sys
        character(len=*), intent(in) :: system
        real(wp), intent(in) :: q0(:), p0(:), q_ref(:), p_ref(:)
        integer, intent(in) :: err_unit
        type(bench_row_t), allocatable, intent(inout) :: rows(:)
        type(bench_row_t) :: row
        type(holosym_status_t) :: run_status
        integer :: t
        do t = 1, size(bench_targets)
            if (.not. target_in_precision(bench_targets(t), &
                                          trim(merge("real64 ", "real128", wp_is_double)))) cycle
            call accuracy_run(sys, q0, p0, bench_span(system), bench_targets(t), q_ref, p_ref, &
                              row, run_status)
            row%system = system
            rows = [rows, row]
            if (run_status%ok()) then
                write (err_unit, '(a)') "bench: " // system // " --accuracy " // &
                    real_str(bench_targets(t)) // ": (" // int_str(row%order_m) // "," // &
                    int_str(row%order_n) // "," // int_str(row%gauss_points) // ") " // &
                    int_str(row%steps) // " steps, error " // real_str(row%error) // ", " // &
                    seconds_text(row%compile_seconds) // " + " // seconds_text(row%seconds) // &
                    " s"
            else
                write (err_unit, '(a)') "bench: " // system // " --accuracy " // &
                    real_str(bench_targets(t)) // ": " // trim(status_code_name(run_status%code)) &
                    // ": " // run_status%message
            end if
        end do
    end subroutine accuracy_rows

    !> The number of sweeps `run_bench` makes (the N of its progress lines): per selected
    !! system 2 M_max holosym sweeps, the looser tolerances' (real128) and RATTLE's.
    integer function sweep_count(options) result(count)
        type(bench_options_t), intent(in) :: options
        integer :: s, per_system
        per_system = 2 * options%max_m + count_rattle()
        if (.not. wp_is_double) per_system = per_system + &
            size(loose_tolerances) * max(0, min(8, options%max_m) - 1)
        count = 0
        do s = 1, size(bench_systems)
            if (selected(options%systems, bench_systems(s))) count = count + per_system
        end do
    contains
        integer function count_rattle()
            integer :: family
            count_rattle = 0
            do family = 1, size(rattle_families)
                if (rattle_orders(family) <= options%max_rattle_order) &
                    count_rattle = count_rattle + 1
            end do
        end function count_rattle
    end function sweep_count

    !> heyoka's sweep of one system: tools/heyoka_bench.py run (without a shell) with the
    !! --heyoka Python, its rows written to a scratch file, read back strictly (bench CSV,
    !! method heyoka, this system and precision), added to `rows` and the whole of `rows`
    !! written to `csv` through `output_t`.
    subroutine heyoka_sweep(options, system, csv, err_unit, rows, status)
        type(bench_options_t), intent(in) :: options
        character(len=*), intent(in) :: system, csv
        integer, intent(in) :: err_unit
        type(bench_row_t), allocatable, intent(inout) :: rows(:) !! heyoka's rows so far
        type(holosym_status_t), intent(inout) :: status
        type(text_t), allocatable :: argv(:)
        type(bench_row_t), allocatable :: new_rows(:)
        character(len=:), allocatable :: part, precision
        integer :: exit_code, k
        part = csv // ".part"
        precision = trim(merge("real64 ", "real128", wp_is_double))
        call remove_file(part, status)
        if (.not. status%ok()) return
        allocate (argv(0))
        call append_text(argv, options%heyoka)
        call append_text(argv, heyoka_script)
        call append_text(argv, "sweep")
        call append_text(argv, "--system")
        call append_text(argv, system)
        call append_text(argv, "--precision")
        call append_text(argv, precision)
        call append_text(argv, "--reference")
        call append_text(argv, reference_path(options))
        call append_text(argv, "--out")
        call append_text(argv, part)
        call append_text(argv, "--budget")
        call append_text(argv, trim(scientific_field(real(options%budget, wp))))
        if (options%quick) call append_text(argv, "--quick")
        write (err_unit, '(a)') "bench: " // command_text(argv)
        call run_program(argv, "", exit_code, status)
        if (.not. status%ok()) then
            status%message = "the heyoka sweep could not be started: " // status%message
            return
        end if
        if (exit_code /= 0) then
            call fail(status, "the heyoka sweep failed (exit status " // int_str(exit_code) // &
                "): " // command_text(argv))
            return
        end if
        allocate (new_rows(0))
        call read_bench_csv(part, new_rows, status)
        if (.not. status%ok()) return
        do k = 1, size(new_rows)
            if (new_rows(k)%method /= "heyoka" .or. new_rows(k)%system /= system .or. &
                new_rows(k)%precision /= precision) then
                call fail(status, part // ": line " // int_str(k + 1) // ": a row of " // &
                    trim(new_rows(k)%method) // ", " // trim(new_rows(k)%system) // ", " // &
                    trim(new_rows(k)%precision) // "; the heyoka sweep of " // system // &
                    " in " // precision // " should give only its own")
                return
            end if
        end do
        rows = [rows, new_rows]
        call write_bench_csv(csv, rows, status)
        if (status%ok()) call remove_file(part, status)
    end subroutine heyoka_sweep

    !> The reference file of a run: --reference, else DIR/reference.csv.
    function reference_path(options) result(path)
        type(bench_options_t), intent(in) :: options
        character(len=:), allocatable :: path
        path = options%reference
        if (len(path) == 0) path = options%out_dir // "/reference.csv"
    end function reference_path

    !> Cheapest successful row of a method family meeting an error target (holosym: the
    !! sweeps' rows, not the plain path's nor those through --accuracy).
    pure integer function cheapest(rows, system, prefix, precision, target)
        type(bench_row_t), intent(in) :: rows(:)
        character(len=*), intent(in) :: system, prefix, precision
        real(wp), intent(in) :: target
        integer :: i
        cheapest = 0
        do i = 1, size(rows)
            if (trim(rows(i)%system) /= system .or. trim(rows(i)%precision) /= precision) cycle
            if (index(rows(i)%method, prefix) /= 1 .or. rows(i)%method == "holosym-plain" .or. &
                rows(i)%method == "holosym-accuracy") cycle
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

    !> Description of a row's configuration.
    function config_text(row) result(text)
        type(bench_row_t), intent(in) :: row
        character(len=:), allocatable :: text
        character(len=16) :: buffer
        write (buffer, '(g0.4)') real(row%h, real64)
        ! The leading zero of 0.25 is optional in the standard: written alike everywhere.
        if (buffer(1:1) == '.') buffer = '0' // buffer
        if (index(row%method, "holosym") == 1) then
            text = "(" // int_str(row%order_m) // "," // int_str(row%order_n) // "," // &
                int_str(row%gauss_points) // ") h=" // trim(buffer)
            if (row%tolerance > 0 .and. row%method /= "holosym-accuracy") then
                write (buffer, '(es8.1)') real(row%tolerance, real64)
                text = text // " Newton tol " // trim(adjustl(buffer))
            end if
        else
            text = trim(row%method(8:)) // " p=" // int_str(row%order) // " h=" // trim(buffer)
        end if
    end function config_text

    !> Description of a heyoka row: its tolerance and Taylor order.
    function heyoka_text(row) result(text)
        type(bench_row_t), intent(in) :: row
        character(len=:), allocatable :: text
        character(len=16) :: buffer
        write (buffer, '(es8.1)') real(row%tolerance, real64)
        text = "tol " // trim(adjustl(buffer)) // ", order " // int_str(row%order)
    end function heyoka_text

    !> A small number for a table: two digits.
    function short_real(value) result(text)
        real(wp), intent(in) :: value
        character(len=:), allocatable :: text
        character(len=16) :: buffer
        write (buffer, '(es9.1)') real(value, real64)
        text = trim(adjustl(buffer))
    end function short_real

    !> The Markdown summary: per precision, target and system the cheapest configuration
    !! of holosym, of RATTLE composed inside holosym and of heyoka (index-1 form) reaching
    !! the target, with the ratios of their CPU times and heyoka's whole-run residuals.
    subroutine write_summary(rows, steps_rows, out, nested)
        type(bench_row_t), intent(in) :: rows(:)       !! sweep rows (any precision, any method)
        type(bench_row_t), intent(in) :: steps_rows(:) !! per-step comparison rows
        type(output_t), intent(inout) :: out           !! where the Markdown goes
        logical, intent(in), optional :: nested        !! headings one level down
        integer :: t, s, k, best, rival, taylor, precision, c, variant, plain
        integer, allocatable :: pairs(:, :)
        character(len=:), allocatable :: line, prec, level
        real(real64) :: per_step, plain_step
        real(wp) :: difference
        level = "#"
        if (present(nested)) then
            if (nested) level = "##"
        end if
        call out%line(level // " holosym work-precision benchmark")
        call out%line("")
        call out%line("Error = max(|q - q_ref|, |p - p_ref|) at T against one reference " // &
            "(holosym M = 8 at h = 1/32; reference.csv), the same for every method. CPU " // &
            "seconds on one core, median of 3 for runs under 0.2 s; the cheapest run of " // &
            "each method reaching the target. holosym: default options (real128: also " // &
            "Newton tolerances 1e-12, 1e-18 and 1e-24 for M = 2..8). RATTLE: composed " // &
            "inside holosym (GNI_COMP's compositions, orders 2-10). heyoka: Taylor method " // &
            "on the index-1 form (tools/heyoka_bench.py), compile time apart; its max " // &
            "residual (max |phi|, |Phi H_p| over the run) and energy error are whole-run. " // &
            "'x' = the method's time / holosym's (above 1: holosym is faster).")
        do precision = 2, 1, -1
            prec = merge("real128", "real64 ", precision == 2)
            if (.not. any(rows%precision == prec)) cycle
            call out%line("")
            call out%line(level // "# " // trim(prec))
            call out%line("")
            call out%line("| target | system | holosym config | holosym s | " // &
                "RATTLE config | RATTLE s | x RATTLE | heyoka config | heyoka s | x heyoka | " &
                // "heyoka compile s | heyoka max residual | heyoka energy error |")
            call out%line("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
            pairs = bench_pairs(trim(prec))
            do k = 1, size(pairs, 2)
                t = pairs(1, k)
                s = pairs(2, k)
                if (.not. any(rows%system == bench_systems(s))) cycle
                best = cheapest(rows, trim(bench_systems(s)), "holosym", trim(prec), &
                                bench_targets(t))
                rival = cheapest(rows, trim(bench_systems(s)), "rattle", trim(prec), &
                                 bench_targets(t))
                taylor = cheapest(rows, trim(bench_systems(s)), "heyoka", trim(prec), &
                                  bench_targets(t))
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
                        seconds_text(rows(rival)%seconds) // " | " // &
                        ratio(rival) // " | "
                else
                    line = line // "— | — | — | "
                end if
                if (taylor > 0) then
                    line = line // heyoka_text(rows(taylor)) // " | " // &
                        seconds_text(rows(taylor)%seconds) // " | " // ratio(taylor) // &
                        " | " // seconds_text(rows(taylor)%compile_seconds) // " | " // &
                        short_real(rows(taylor)%constraint_residual) // " | " // &
                        short_real(rows(taylor)%energy_error) // " |"
                else
                    line = line // "— | — | — | — | — | — |"
                end if
                call out%line(line)
            end do
        end do
        call accuracy_summary(rows, out, level)
        if (size(steps_rows) == 0) return
        call out%line("")
        call out%line(level // "# Per-step cost of the speed options " // &
            "(spherical pendulum, h = 1/8, T = 10)")
        call out%line("")
        call out%line("Option sets 0 to 8 run the general step (`structured = .false.`), " // &
            "which honours each option alone; the last row is the defaults, the reduced step.")
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
                " | " // ratio_text(plain_step / per_step) // " | " // &
                ratio_text(real(steps_rows(c)%newton_iterations, real64) / &
                           steps_rows(c)%steps) // " | " // &
                ratio_text(real(steps_rows(c)%factorizations, real64) / steps_rows(c)%steps) &
                // " | " // ratio_text(real(steps_rows(c)%gradients, real64) / &
                steps_rows(c)%steps) // " | " // trim(real_str(difference)) // " |")
        end do
    contains
        !> rows(other)%seconds / rows(best)%seconds, or "—" without a holosym row.
        function ratio(other) result(text)
            integer, intent(in) :: other
            character(len=:), allocatable :: text
            if (best > 0) then
                text = ratio_text(rows(other)%seconds / rows(best)%seconds)
            else
                text = "—"
            end if
        end function ratio
    end subroutine write_summary

    !> The (target, system) pairs of a precision's tables: column k holds the index into
    !! `bench_targets` and into `bench_systems`, targets in order, systems within a target.
    pure function bench_pairs(precision) result(pairs)
        character(len=*), intent(in) :: precision !! real128 or real64
        integer, allocatable :: pairs(:, :)
        integer :: t, s, k
        allocate (pairs(2, count([(target_in_precision(bench_targets(t), precision), &
                                   t = 1, size(bench_targets))]) * size(bench_systems)))
        k = 0
        do t = 1, size(bench_targets)
            if (.not. target_in_precision(bench_targets(t), precision)) cycle
            do s = 1, size(bench_systems)
                k = k + 1
                pairs(:, k) = [t, s]
            end do
        end do
    end function bench_pairs

    !> The row through --accuracy of a system, precision and target (0: none).
    pure integer function accuracy_index(rows, system, precision, target) result(found)
        type(bench_row_t), intent(in) :: rows(:)
        character(len=*), intent(in) :: system, precision
        real(wp), intent(in) :: target
        integer :: i
        found = 0
        do i = 1, size(rows)
            if (trim(rows(i)%system) /= system .or. trim(rows(i)%precision) /= precision) cycle
            if (rows(i)%method /= "holosym-accuracy") cycle
            if (abs(rows(i)%tolerance - target) <= 1.0e-6_wp * target) found = i
        end do
    end function accuracy_index

    !> The runs through --accuracy of a precision, one per (target, system) pair that has
    !! one (`bench_pairs` order), each with heyoka's cheapest run reaching the target.
    function accuracy_matches(rows, precision) result(matches)
        type(bench_row_t), intent(in) :: rows(:)
        character(len=*), intent(in) :: precision
        type(accuracy_match_t), allocatable :: matches(:)
        type(accuracy_match_t) :: match
        integer, allocatable :: pairs(:, :)
        integer :: k
        pairs = bench_pairs(precision)
        allocate (matches(0))
        do k = 1, size(pairs, 2)
            match%target = bench_targets(pairs(1, k))
            match%system = bench_systems(pairs(2, k))
            match%chosen = accuracy_index(rows, trim(match%system), precision, match%target)
            if (match%chosen == 0) cycle
            match%taylor = cheapest(rows, trim(match%system), "heyoka", precision, &
                                    match%target)
            matches = [matches, match]
        end do
    end function accuracy_matches

    !> The tables of the runs through --accuracy, per precision: the plan, the error
    !! reached, the pilot's and the run's CPU seconds, and heyoka's cheapest run reaching
    !! the target against the run alone and against pilot and run together.
    subroutine accuracy_summary(rows, out, level)
        type(bench_row_t), intent(in) :: rows(:)
        type(output_t), intent(inout) :: out
        character(len=*), intent(in) :: level
        integer :: precision, k, chosen, taylor
        type(accuracy_match_t), allocatable :: matches(:)
        character(len=:), allocatable :: prec, line
        do precision = 2, 1, -1
            prec = merge("real128", "real64 ", precision == 2)
            if (.not. any(rows%precision == prec .and. rows%method == "holosym-accuracy")) cycle
            call out%line("")
            call out%line(level // "# " // trim(prec) // " through --accuracy")
            call out%line("")
            call out%line("holosym as `holosym simulate --accuracy TARGET --T T` runs it " // &
                "(`init_for_accuracy`: a pilot chooses (M, N, G), h and the Newton " // &
                "tolerance, then the run), against heyoka's cheapest run reaching the " // &
                "target (its tolerance chosen after the fact, compile time apart).")
            call out%line("")
            call out%line("| target | system | plan | error at T | pilot s | run s | " // &
                "heyoka s | x heyoka (run) | x heyoka (pilot + run) |")
            call out%line("|---|---|---|---|---|---|---|---|---|")
            matches = accuracy_matches(rows, trim(prec))
            do k = 1, size(matches)
                chosen = matches(k)%chosen
                taylor = matches(k)%taylor
                line = "| " // trim(real_str(matches(k)%target)) // " | " // &
                    trim(matches(k)%system) // " | "
                if (rows(chosen)%code /= HOLOSYM_SUCCESS) then
                    line = line // "refused: " // trim(status_code_name(rows(chosen)%code)) &
                        // " | — | — | — | "
                else
                    line = line // config_text(rows(chosen)) // ", " // &
                        int_str(rows(chosen)%steps) // " steps | " // &
                        short_real(rows(chosen)%error) // " | " // &
                        seconds_text(rows(chosen)%compile_seconds) // " | " // &
                        seconds_text(rows(chosen)%seconds) // " | "
                end if
                if (taylor > 0 .and. rows(chosen)%code == HOLOSYM_SUCCESS) then
                    line = line // seconds_text(rows(taylor)%seconds) // " | " // &
                        ratio_text(rows(taylor)%seconds / rows(chosen)%seconds) // " | " // &
                        ratio_text(rows(taylor)%seconds / (rows(chosen)%seconds + &
                        rows(chosen)%compile_seconds)) // " |"
                else if (taylor > 0) then
                    line = line // seconds_text(rows(taylor)%seconds) // " | — | — |"
                else
                    line = line // "— | — | — |"
                end if
                call out%line(line)
            end do
        end do
    end subroutine accuracy_summary

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
        if (len(options%long_section) > 0) then
            ! A malformed long.csv fails the command, naming the line (the section alone
            ! would print it as missing).
            call check_report_files(options%long_section, status)
            if (status%ok()) call long_section(options%long_section, out)
            call finish(status)
            return
        end if
        if (len(options%models_section) > 0) then
            call models_section(options%models_section, out)
            exit_code = EXIT_OK
            return
        end if
        if (options%scaling_point > 0) then
            call scaling_point(options%scaling_point, options%general, options%quick, &
                               out, status)
            call finish(status)
            return
        end if
        if (options%accuracy) then
            call make_directories(options%out_dir, status)
            if (status%ok()) call run_accuracy(options%out_dir, err_unit, status)
            call finish(status)
            return
        end if
        if (options%scaling .or. options%long .or. options%models) then
            call make_directories(options%out_dir, status)
            if (options%scaling .and. status%ok()) call run_scaling(options, err_unit, status)
            if (options%models .and. status%ok()) call run_models(options%out_dir, &
                options%quick, err_unit, status)
            if (options%long .and. status%ok()) call run_long(options%out_dir, &
                options%heyoka, options%quick, err_unit, status)
            if (status%ok()) call write_reports(options%out_dir, status)
            call finish(status)
            return
        end if
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
                    "/" // trim(merge("steps64.csv", "steps.csv  ", wp_is_double)), steps_rows, &
                    status)
            end if
        end if
        allocate (all_rows(0))
        if (allocated(steps_rows)) deallocate (steps_rows)
        allocate (steps_rows(0))
        if (status%ok()) call read_bench_csv(dir // "/bench.csv", all_rows, status, .true.)
        if (status%ok()) call read_bench_csv(dir // "/bench64.csv", all_rows, status, .true.)
        if (status%ok()) call read_bench_csv(dir // "/heyoka.csv", all_rows, status, .true.)
        if (status%ok()) call read_bench_csv(dir // "/heyoka64.csv", all_rows, status, .true.)
        if (status%ok()) call read_bench_csv(dir // "/steps.csv", steps_rows, status, .true.)
        if (status%ok()) call read_bench_csv(dir // "/steps64.csv", steps_rows, status, .true.)
        if (status%ok() .and. size(all_rows) + size(steps_rows) == 0) call fail(status, &
            "no bench.csv, bench64.csv, steps.csv or steps64.csv in " // dir)
        if (.not. status%ok()) then
            write (err_unit, '(a)') "holosym bench: " // status%message
            exit_code = EXIT_FAILURE
            return
        end if
        call write_summary(all_rows, steps_rows, out)
        call open_output(dir // "/summary.md", file, status)
        if (status%ok()) then
            call write_summary(all_rows, steps_rows, file)
            call file%close(status)
        end if
        if (status%ok()) call write_reports(dir, status)
        call finish(status)
    contains
        !> Exit code and message of the command.
        subroutine finish(outcome)
            type(holosym_status_t), intent(in) :: outcome
            if (outcome%ok()) then
                exit_code = EXIT_OK
            else
                write (err_unit, '(a)') "holosym bench: " // outcome%message
                exit_code = EXIT_FAILURE
            end if
        end subroutine finish
    end subroutine bench_command

    !> DIR/performance.md from every CSV file in DIR.
    subroutine write_reports(dir, status)
        character(len=*), intent(in) :: dir
        type(holosym_status_t), intent(inout) :: status
        type(bench_row_t), allocatable :: rows(:), steps_rows(:)
        type(output_t) :: file
        integer :: k
        character(len=12), parameter :: files(4) = [character(len=12) :: "bench.csv", &
            "bench64.csv", "heyoka.csv", "heyoka64.csv"]
        allocate (rows(0), steps_rows(0))
        do k = 1, size(files)
            if (status%ok()) call read_bench_csv(dir // "/" // trim(files(k)), rows, status, &
                                                 .true.)
        end do
        if (status%ok()) call read_bench_csv(dir // "/steps.csv", steps_rows, status, .true.)
        if (status%ok()) call read_bench_csv(dir // "/steps64.csv", steps_rows, status, .true.)
        call check_report_files(dir, status)
        if (.not. status%ok()) return
        call open_output(dir // "/performance.md", file, status)
        if (.not. status%ok()) return
        call write_performance(dir, rows, steps_rows, file)
        call file%close(status)
    end subroutine write_reports

    !> Verdicts on the speed targets at fixed T: for each precision, target and system,
    !! heyoka's time / holosym's against the required ratio.
    subroutine target_verdicts(rows, unit)
        type(bench_row_t), intent(in) :: rows(:)
        type(output_t), intent(inout) :: unit !! the page
        integer :: precision, t, s, k, best, taylor, met, total
        integer, allocatable :: pairs(:, :)
        real(real64) :: required, ratio, worst
        character(len=:), allocatable :: prec, smallest
        do precision = 1, 2
            prec = merge("real128", "real64 ", precision == 2)
            required = merge(2.0_real64, 1.0_real64, precision == 2)
            met = 0
            total = 0
            worst = huge(1.0_real64)
            pairs = bench_pairs(trim(prec))
            do k = 1, size(pairs, 2)
                t = pairs(1, k)
                s = pairs(2, k)
                taylor = cheapest(rows, trim(bench_systems(s)), "heyoka", trim(prec), &
                                  bench_targets(t))
                if (taylor == 0) cycle  ! heyoka does not reach it: no comparison
                total = total + 1
                best = cheapest(rows, trim(bench_systems(s)), "holosym", trim(prec), &
                                bench_targets(t))
                if (best == 0) cycle
                ratio = rows(taylor)%seconds / rows(best)%seconds
                worst = min(worst, ratio)
                if (ratio >= required) met = met + 1
            end do
            if (total == 0) then
                call unit%line("- " // trim(prec) // ": no heyoka rows (run with --heyoka).")
            else
                smallest = "—"
                if (worst < huge(1.0_real64)) smallest = ratio_text(worst)
                call unit%line("- " // trim(prec) // " (holosym at least " // &
                    ratio_text(required) // "x faster than heyoka wherever heyoka reaches " // &
                    "the target): met at " // int_str(met) // " of " // int_str(total) // &
                    " (target, system) pairs; smallest heyoka / holosym ratio " // smallest // &
                    " (pairs holosym does not reach count as missed).")
            end if
        end do
    end subroutine target_verdicts

    !> Verdicts on the targets through --accuracy: per precision, heyoka's time / holosym's
    !! (pilot and run) against the required ratio (real128 2, real64 0.5) wherever heyoka
    !! reaches the target, and the largest error / request of holosym's runs.
    subroutine accuracy_verdicts(rows, unit)
        type(bench_row_t), intent(in) :: rows(:)
        type(output_t), intent(inout) :: unit !! the page
        integer :: precision, k, chosen, taylor, met, total
        type(accuracy_match_t), allocatable :: matches(:)
        real(real64) :: required, ratio, worst
        real(wp) :: overshoot
        character(len=:), allocatable :: prec, smallest
        do precision = 2, 1, -1
            prec = merge("real128", "real64 ", precision == 2)
            if (.not. any(rows%precision == prec .and. rows%method == "holosym-accuracy")) cycle
            required = merge(2.0_real64, 0.5_real64, precision == 2)
            met = 0
            total = 0
            worst = huge(1.0_real64)
            overshoot = 0
            matches = accuracy_matches(rows, trim(prec))
            do k = 1, size(matches)
                chosen = matches(k)%chosen
                taylor = matches(k)%taylor
                if (rows(chosen)%code == HOLOSYM_SUCCESS) overshoot = max(overshoot, &
                    rows(chosen)%error / matches(k)%target)
                if (taylor == 0) cycle  ! heyoka does not reach it: no comparison
                total = total + 1
                if (rows(chosen)%code /= HOLOSYM_SUCCESS) cycle
                ratio = rows(taylor)%seconds / (rows(chosen)%seconds + &
                                                rows(chosen)%compile_seconds)
                worst = min(worst, ratio)
                if (ratio >= required) met = met + 1
            end do
            smallest = "—"
            if (worst < huge(1.0_real64)) smallest = ratio_text(worst)
            call unit%line("- " // trim(prec) // " through `--accuracy` (pilot and run " // &
                "together at least " // ratio_text(required) // "x faster than heyoka " // &
                "wherever heyoka reaches the target): met at " // int_str(met) // " of " // &
                int_str(total) // " pairs; smallest ratio " // smallest // "; the error " // &
                "reached is at most " // ratio_text(real(overshoot, real64)) // &
                " times the request.")
        end do
    end subroutine accuracy_verdicts

    !> docs/performance.md: how it was measured, the targets with their measured ratios,
    !! the work-precision tables, the scaling and long-run sections and the figures.
    subroutine write_performance(dir, rows, steps_rows, unit)
        character(len=*), intent(in) :: dir
        type(bench_row_t), intent(in) :: rows(:), steps_rows(:)
        type(output_t), intent(inout) :: unit !! the page
        type(text_t), allocatable :: environment(:)
        type(holosym_status_t) :: local
        logical :: exists
        integer :: k
        call unit%line("# Performance")
        call unit%line("")
        call unit%line("Generated by `make bench` (`holosym bench --summarize " // dir // &
            "` from the CSV files there); edits are overwritten. Every number below was " // &
            "measured in that run: holosym, RATTLE composed inside holosym and heyoka side " // &
            "by side, against one reference.")
        call unit%line("")
        call unit%line("## How it was measured")
        call unit%line("")
        call unit%line("- `make bench`: `holosym bench --heyoka PYTHON` in the real128 " // &
            "build (writes the reference), the same in the real64 build against that " // &
            "reference, `holosym bench --scaling` in both builds, then plots and this page. " // &
            "`make bench-long`: `holosym bench --long --heyoka PYTHON` (about 80 minutes here).")
        call unit%line("- Competitor: heyoka (the `heyoka` package on PyPI, Taylor " // &
            "method with LLVM compilation), installed by `tools/bench_venv.sh` into the " // &
            "benchmark's virtual environment, run by `tools/heyoka_bench.py` on the index-1 " // &
            "form of each system (Cartesian coordinates, the multipliers from the twice " // &
            "differentiated constraint), same H, parameters and initial states; tolerance " // &
            "swept by decades, compile time excluded and reported apart.")
        ! The machine and versions (tools/bench_environment.sh), when the file is there.
        inquire (file=dir // "/environment.txt", exist=exists)
        if (exists) then
            call read_text_file(dir // "/environment.txt", environment, local)
            if (.not. local%ok()) then
                call unit%line("- (environment.txt not read: " // local%message // ")")
            else
                do k = 1, size(environment)
                    call unit%line("- " // trim(environment(k)%text))
                end do
            end if
        end if
        call unit%line("")
        call unit%line("## Targets at fixed T, measured")
        call unit%line("")
        call target_verdicts(rows, unit)
        call accuracy_verdicts(rows, unit)
        call unit%line("")
        call unit%line("Where a target is missed, the profile of a step and the least a step of this " // &
            "design costs are in [design.md](design.md#where-the-time-goes-and-what-this-design-" // &
            "cannot-do) (callgrind counts, with the commands).")
        call unit%line("")
        call unit%line("![work-precision](figures/work_precision.png)")
        call unit%line("")
        call write_summary(rows, steps_rows, unit, nested=.true.)
        call scaling_section(dir, unit)
        call unit%line("")
        call unit%line("![cost against K](figures/scaling.png)")
        call models_section(dir, unit)
        call long_section(dir, unit)
    end subroutine write_performance

    !> The scaling study: every (K, path) in a child process (the same executable, run
    !! without a shell) whose CSV line goes to a scratch file; the lines so far are
    !! written to DIR/scaling.csv (scaling64.csv) through `output_t` after each point.
    subroutine run_scaling(options, err_unit, status)
        type(bench_options_t), intent(in) :: options
        integer, intent(in) :: err_unit
        type(holosym_status_t), intent(inout) :: status
        character(len=:), allocatable :: executable, csv, part
        type(text_t), allocatable :: argv(:), lines(:), point(:), fields(:)
        integer, allocatable :: links(:)
        integer :: k, path, length, exit_code
        call get_command_argument(0, length=length)
        allocate (character(len=length) :: executable)
        call get_command_argument(0, executable)
        csv = options%out_dir // "/" // trim(merge("scaling64.csv", "scaling.csv  ", &
                                                   wp_is_double))
        part = csv // ".point"
        allocate (lines(0))
        call append_text(lines, scaling_header)
        call write_lines(csv, lines, status)
        if (.not. status%ok()) return
        links = scaling_links(options%quick)
        do k = 1, size(links)
            do path = 1, 2
                if (path == 2 .and. links(k) > general_links_limit(options%quick)) cycle
                if (allocated(argv)) deallocate (argv)
                allocate (argv(0))
                call append_text(argv, executable)
                call append_text(argv, "bench")
                call append_text(argv, "--scaling-point")
                call append_text(argv, int_str(links(k)))
                if (path == 2) call append_text(argv, "--general")
                if (options%quick) call append_text(argv, "--quick")
                call run_program(argv, part, exit_code, status)
                if (.not. status%ok()) return
                if (exit_code /= 0) then
                    call fail(status, "scaling point failed (exit status " // &
                        int_str(exit_code) // "): " // command_text(argv))
                    return
                end if
                call read_text_file(part, point, status)
                if (.not. status%ok()) return
                if (size(point) == 1) call split_fields(point(1)%text, fields)
                if (size(point) /= 1) then
                    call fail(status, part // ": expected one CSV line from " // &
                        command_text(argv) // "; got " // int_str(size(point)))
                    return
                else if (size(fields) /= 9) then
                    call fail(status, part // ": expected 9 fields from " // &
                        command_text(argv) // "; got " // int_str(size(fields)))
                    return
                end if
                call append_text(lines, point(1)%text)
                call write_lines(csv, lines, status)
                if (.not. status%ok()) return
                write (err_unit, '(a)') "bench --scaling: K = " // int_str(links(k)) // &
                    merge(" general", " reduced", path == 2) // " done"
            end do
        end do
        call remove_file(part, status)
    end subroutine run_scaling

end module holosym_cli_bench

!> Holds `not_installed`: fpm installs no module of a source with a submodule.
submodule (holosym_cli_bench) holosym_cli_bench_app
    implicit none
contains
    module procedure not_installed
    end procedure not_installed
end submodule holosym_cli_bench_app
