!> Sections of docs/performance.md from the CSV files of `holosym bench --scaling`
!! (DIR/scaling.csv, scaling64.csv) and `--long` (DIR/long.csv): tables, the fitted
!! exponent of the cost per step against K, and the verdicts on the scaling and long-run
!! targets. Missing files give a line saying which command makes them; the files are
!! read strictly (`check_report_files` before the page is written: `bench --summarize`
!! fails on a malformed file instead of printing NaN or garbage).
module holosym_bench_report
    use, intrinsic :: iso_fortran_env, only: real64
    use holosym_kinds, only: wp
    use holosym_status_codes, only: holosym_status_t, status_code_name, HOLOSYM_SUCCESS
    use holosym_output, only: output_t, text_t, read_text_file
    use holosym_cli_common, only: parse_integer, parse_real, fail
    use holosym_bench_scaling, only: scaling_header
    use holosym_bench_long, only: long_header
    use holosym_bench_models, only: models_header, model_scaling_header, &
        model_instructions_header, model_scaling_instructions_header
    implicit none
    private

    public :: scaling_section, long_section, models_section, read_csv, csv_table_t, &
        check_report_files

    !> Largest cost ratio of a model file to its built-in twin (the target).
    real(real64), parameter :: model_ratio_target = 1.3_real64
    !> Largest exponent of the model-file chain's cost per step against K (the target).
    real(real64), parameter :: model_exponent_target = 1.1_real64
    !> Longest load of the 256-link chain's model file, seconds (the target).
    real(real64), parameter :: model_load_target = 1.0_real64

    !> Largest time in seconds a file may give (a bound that keeps ratios finite).
    real(wp), parameter :: max_seconds = 1.0e12_wp

    !> Longest field of a CSV line.
    integer, parameter :: field_length = 64

    !> A CSV file: header names and rows of fields.
    type :: csv_table_t
        character(len=field_length), allocatable :: names(:)    !! the header's fields
        character(len=field_length), allocatable :: cells(:, :) !! field, row
    end type csv_table_t

    interface
        !> Does nothing. Its body, in the submodule at the end of this file, keeps this
        !! application module out of `fpm install` (see fpm.toml).
        module subroutine not_installed()
        end subroutine not_installed
    end interface

contains

    !> Read the CSV file `path` whose first line must be `header`; `found` false when the
    !! file does not exist. Every row must have the header's fields, each in its range
    !! (`field_ok`); a field longer than `field_length` is refused. Failure
    !! (HOLOSYM_INVALID_ARGUMENT: not text, another header, a row with other fields, a
    !! value out of its range) names the file, the line and the field.
    subroutine read_csv(path, header, table, found, status)
        character(len=*), intent(in) :: path      !! the file
        character(len=*), intent(in) :: header    !! its expected first line
        type(csv_table_t), intent(out) :: table   !! its contents
        logical, intent(out) :: found             !! the file exists
        type(holosym_status_t), intent(out) :: status !! outcome
        type(text_t), allocatable :: lines(:)
        character(len=field_length), allocatable :: fields(:)
        character(len=:), allocatable :: problem
        integer :: row, k
        logical :: ok
        status%code = HOLOSYM_SUCCESS
        status%message = ""
        allocate (table%names(0), table%cells(0, 0))
        inquire (file=path, exist=found)
        if (.not. found) return
        call read_text_file(path, lines, status)
        if (.not. status%ok()) return
        if (size(lines) == 0) then
            call fail(status, path // ": line 1: not the header " // header)
            return
        end if
        if (lines(1)%text /= header) then
            call fail(status, path // ": line 1: not the header " // header)
            return
        end if
        table%names = split(header)
        deallocate (table%cells)
        allocate (table%cells(size(table%names), size(lines) - 1))
        do row = 2, size(lines)
            call split_checked(lines(row)%text, size(table%names), fields, ok)
            if (.not. ok) then
                call fail(status, path // ": line " // int_text(row) // ": expected " // &
                    int_text(size(table%names)) // " comma-separated fields of at most " // &
                    int_text(field_length) // " characters")
                return
            end if
            do k = 1, size(fields)
                problem = field_problem(trim(table%names(k)), trim(fields(k)))
                if (len(problem) > 0) then
                    call fail(status, path // ": line " // int_text(row) // ": field " // &
                        trim(table%names(k)) // " " // problem // ": '" // trim(fields(k)) // "'")
                    return
                end if
            end do
            table%cells(:, row - 1) = fields
        end do
    end subroutine read_csv

    !> Fail when a scaling or long-run file in `dir` is malformed (see `read_csv`);
    !! missing files are no error.
    subroutine check_report_files(dir, status)
        character(len=*), intent(in) :: dir !! directory of the CSV files
        type(holosym_status_t), intent(inout) :: status !! failure naming file and line
        type(csv_table_t) :: table
        logical :: found
        if (status%ok()) call read_csv(dir // "/scaling.csv", scaling_header, table, found, &
                                       status)
        if (status%ok()) call read_csv(dir // "/scaling64.csv", scaling_header, table, found, &
                                       status)
        if (status%ok()) call read_csv(dir // "/long.csv", long_header, table, found, status)
        if (status%ok()) call read_csv(dir // "/models.csv", models_header, table, found, status)
        if (status%ok()) call read_csv(dir // "/models64.csv", models_header, table, found, &
                                       status)
        if (status%ok()) call read_csv(dir // "/model_scaling.csv", model_scaling_header, &
                                       table, found, status)
        if (status%ok()) call read_csv(dir // "/model_instructions.csv", &
                                       model_instructions_header, table, found, status)
        if (status%ok()) call read_csv(dir // "/model_instructions64.csv", &
                                       model_instructions_header, table, found, status)
        if (status%ok()) call read_csv(dir // "/model_scaling_instructions.csv", &
                                       model_scaling_instructions_header, table, found, status)
        if (status%ok()) call read_csv(dir // "/model_scaling_instructions64.csv", &
                                       model_scaling_instructions_header, table, found, status)
        if (status%ok()) call read_csv(dir // "/model_scaling64.csv", model_scaling_header, &
                                       table, found, status)
    end subroutine check_report_files

    !> What is wrong with the value `text` of the column `name` ("" when it is in range):
    !! names from a fixed list (precision, path, system, method), counts and sizes as
    !! integers in range, times in [0, 1e12] seconds, errors and residuals finite >= 0, a
    !! tolerance in [0, 1), a span > 0, status a documented code.
    function field_problem(name, text) result(problem)
        character(len=*), intent(in) :: name, text
        character(len=:), allocatable :: problem
        type(holosym_status_t) :: local
        integer :: integer_value
        real(wp) :: value
        problem = ""
        select case (name)
        case ("precision")
            if (text /= "real128" .and. text /= "real64") problem = "is not real128 or real64"
        case ("path")
            if (text /= "reduced" .and. text /= "general" .and. text /= "model" .and. &
                text /= "builtin") problem = "is not reduced, general, model or builtin"
        case ("model")
            if (text /= "pendulum" .and. text /= "linkage" .and. text /= "chain64") &
                problem = "is not pendulum, linkage or chain64"
        case ("system")
            if (text /= "pendulum" .and. text /= "linkage" .and. text /= "planar") &
                problem = "is not pendulum, linkage or planar"
        case ("method")
            if (text /= "holosym" .and. text /= "holosym-accuracy" .and. text /= "heyoka") &
                problem = "is not holosym, holosym-accuracy or heyoka"
        case ("config")
            if (len(text) == 0) problem = "is empty"
        case ("links", "n", "m", "steps", "max_rss_kb", "status", "M", "N", "G")
            call parse_integer(name, text, integer_value, local)
            if (.not. local%ok()) then
                problem = "is not an integer"
            else if (name == "links" .and. integer_value < 1) then
                problem = "is not >= 1"
            else if (name == "max_rss_kb" .and. integer_value < -1) then
                problem = "is not >= -1"
            else if (name == "status") then
                if (status_code_name(integer_value) == "unknown status") &
                    problem = "is not a holosym status code"
            else if (name /= "max_rss_kb" .and. integer_value < 0) then
                problem = "is not >= 0"
            end if
        case default
            call parse_real(name, text, value, local)
            if (.not. local%ok()) then
                problem = "is not a finite number"
            else if (.not. value >= 0) then
                problem = "is not >= 0"
            else if (name == "span" .and. .not. value > 0) then
                problem = "is not > 0"
            else if (name == "tolerance" .and. .not. value < 1) then
                problem = "is not in [0, 1)"
            else if (index(name, "seconds") > 0 .and. .not. value <= max_seconds) then
                problem = "is more than 1e12 seconds"
            end if
        end select
    end function field_problem

    !> The comma-separated fields of a header line.
    pure function split(line) result(fields)
        character(len=*), intent(in) :: line
        character(len=field_length), allocatable :: fields(:)
        logical :: ok
        call split_checked(line, -1, fields, ok)
    end function split

    !> Split `line` at its commas into `fields`; `ok` false when a field is longer than
    !! `field_length` or, with `expected` >= 0, the count is not `expected`.
    pure subroutine split_checked(line, expected, fields, ok)
        character(len=*), intent(in) :: line
        integer, intent(in) :: expected
        character(len=field_length), allocatable, intent(out) :: fields(:)
        logical, intent(out) :: ok
        integer :: first, comma, count, k, last
        count = 1
        do k = 1, len(line)
            if (line(k:k) == ",") count = count + 1
        end do
        ok = expected < 0 .or. count == expected
        allocate (fields(count))
        first = 1
        do k = 1, count
            comma = index(line(first:), ",")
            last = len(line)
            if (comma > 0) last = first + comma - 2
            if (last - first + 1 > field_length) ok = .false.
            fields(k) = line(first:last)
            first = last + 2
        end do
    end subroutine split_checked

    !> Column of a named field (0 when absent).
    pure integer function column(table, name)
        type(csv_table_t), intent(in) :: table
        character(len=*), intent(in) :: name
        integer :: k
        column = 0
        do k = 1, size(table%names)
            if (trim(table%names(k)) == name) column = k
        end do
    end function column

    !> A field as a real64 number (huge when it is not one).
    real(real64) function number(table, name, row)
        type(csv_table_t), intent(in) :: table
        character(len=*), intent(in) :: name
        integer, intent(in) :: row
        integer :: ios
        number = huge(1.0_real64)
        if (column(table, name) == 0) return
        read (table%cells(column(table, name), row), *, iostat=ios) number
        if (ios /= 0) number = huge(1.0_real64)
    end function number

    function field(table, name, row) result(text)
        type(csv_table_t), intent(in) :: table
        character(len=*), intent(in) :: name
        integer, intent(in) :: row
        character(len=:), allocatable :: text
        text = ""
        if (column(table, name) > 0) text = trim(table%cells(column(table, name), row))
    end function field

    function sci(value) result(text)
        real(real64), intent(in) :: value
        character(len=:), allocatable :: text
        character(len=16) :: buffer
        write (buffer, '(es9.2)') value
        text = trim(adjustl(buffer))
    end function sci

    function fixed(value) result(text)
        real(real64), intent(in) :: value
        character(len=:), allocatable :: text
        character(len=16) :: buffer
        write (buffer, '(f10.2)') value
        text = trim(adjustl(buffer))
    end function fixed

    !> Per-step seconds of (precision, path, K), or -1.
    real(real64) function per_step(table, precision, path, links)
        type(csv_table_t), intent(in) :: table
        character(len=*), intent(in) :: precision, path
        integer, intent(in) :: links
        integer :: r
        per_step = -1
        do r = 1, size(table%cells, 2)
            if (field(table, "precision", r) == precision .and. field(table, "path", r) == &
                path .and. nint(number(table, "links", r)) == links .and. &
                nint(number(table, "status", r)) == 0) per_step = number(table, &
                "seconds_per_step", r)
        end do
    end function per_step

    !> Least-squares slope of log(seconds per step) against log K over K in [8, 256].
    real(real64) function fitted_exponent(table, precision, path, value) result(slope)
        type(csv_table_t), intent(in) :: table
        character(len=*), intent(in) :: precision, path
        !> The column fitted (default seconds_per_step).
        character(len=*), intent(in), optional :: value
        real(real64) :: x(size(table%cells, 2)), y(size(table%cells, 2))
        character(len=:), allocatable :: name
        integer :: r, count, links
        name = "seconds_per_step"
        if (present(value)) name = value
        count = 0
        do r = 1, size(table%cells, 2)
            links = nint(number(table, "links", r))
            if (field(table, "precision", r) /= precision .or. field(table, "path", r) /= path &
                .or. links < 8 .or. links > 256) cycle
            if (column(table, "status") > 0) then
                if (nint(number(table, "status", r)) /= 0) cycle
            end if
            ! A time of 0 (below the clock's resolution) has no logarithm.
            if (.not. number(table, name, r) > 0) cycle
            count = count + 1
            x(count) = log(real(links, real64))
            y(count) = log(number(table, name, r))
        end do
        slope = -1
        if (count < 2) return
        ! At least two different K (a repeated point gives no slope).
        if (.not. sum((x(:count) - sum(x(:count)) / count)**2) > 0) return
        slope = sum((x(:count) - sum(x(:count)) / count) * (y(:count) - sum(y(:count)) / count)) &
            / sum((x(:count) - sum(x(:count)) / count)**2)
    end function fitted_exponent

    !> The scaling section: table, exponents, memory per link, verdicts.
    subroutine scaling_section(dir, unit)
        character(len=*), intent(in) :: dir !! directory of the CSV files
        type(output_t), intent(inout) :: unit !! the page
        type(csv_table_t) :: both
        logical :: found
        integer :: r, links, k
        integer, allocatable :: all_links(:)
        real(real64) :: values(4), rss_first, rss_last, exponent, at100(2)
        character(len=:), allocatable :: line
        character(len=7), parameter :: precisions(2) = ["real128", "real64 "]
        character(len=7), parameter :: paths(2) = ["reduced", "general"]
        call unit%line("")
        call unit%line("## Scaling: a chain of K planar pendula")
        call unit%line("")
        call read_both(dir, "scaling", scaling_header, both, found)
        if (.not. found) then
            call unit%line("No scaling.csv in " // dir // ": `holosym bench --scaling` " // &
                "makes it.")
            return
        end if
        call unit%line("n = 2K, m = K, (M, N, G) = (4, 3, 5), h = 0.01 (command: " // &
            "`holosym bench --scaling`, in the real128 and real64 builds). Seconds per step; " // &
            "the reduced step is the default, the general path is `structured = .false.` " // &
            "(dense Newton matrices), run while affordable. Peak memory: VmHWM of the " // &
            "process that ran the point.")
        call unit%line("")
        call unit%line("| K | reduced real128 s | general real128 s | reduced real64 s " // &
            "| general real64 s | peak MB (reduced real128) |")
        call unit%line("|---|---|---|---|---|---|")
        allocate (all_links(0))
        do r = 1, size(both%cells, 2)
            links = nint(number(both, "links", r))
            if (.not. any(all_links == links)) all_links = [all_links, links]
        end do
        do k = 1, size(all_links)
            links = all_links(k)
            values = [per_step(both, "real128", "reduced", links), per_step(both, "real128", &
                "general", links), per_step(both, "real64", "reduced", links), &
                per_step(both, "real64", "general", links)]
            line = "| " // int_text(links) // " |"
            do r = 1, 4
                if (values(r) > 0) then
                    line = line // " " // sci(values(r)) // " |"
                else
                    line = line // " — |"
                end if
            end do
            line = line // " " // memory_mb(both, links) // " |"
            call unit%line(line)
        end do
        call unit%line("")
        do k = 1, 2
            do r = 1, 2
                exponent = fitted_exponent(both, trim(precisions(k)), trim(paths(r)))
                if (exponent > 0) call unit%line("- Fitted exponent of the cost per " // &
                    "step against K (K = 8 .. 256), " // trim(paths(r)) // " path, " // &
                    trim(precisions(k)) // ": **" // fixed(exponent) // "** (target: at " // &
                    "most 1.2 for the structured path).")
            end do
        end do
        at100 = [per_step(both, "real128", "reduced", 100), &
                 per_step(both, "real64", "reduced", 100)]
        if (at100(1) > 0) call unit%line("- K = 100, real128: " // &
            fixed(1000 * at100(1)) // " ms per step (target: at most 10 ms): " // &
            verdict(at100(1) <= 0.010_real64))
        if (at100(2) > 0) call unit%line("- K = 100, real64: " // &
            fixed(1000 * at100(2)) // " ms per step (target: at most 0.5 ms): " // &
            verdict(at100(2) <= 0.0005_real64))
        rss_first = -1
        rss_last = -1
        do r = 1, size(both%cells, 2)
            if (field(both, "precision", r) /= "real128" .or. field(both, "path", r) /= &
                "reduced") cycle
            if (nint(number(both, "links", r)) == 1) rss_first = number(both, "max_rss_kb", r)
            if (nint(number(both, "links", r)) == maxval(all_links)) rss_last = &
                number(both, "max_rss_kb", r)
        end do
        if (rss_first > 0 .and. rss_last > 0 .and. maxval(all_links) > 1) call unit%line( &
            "- Peak memory grows by " // fixed((rss_last - rss_first) / &
            (maxval(all_links) - 1)) // " kB per link from K = 1 to " // &
            int_text(maxval(all_links)) // " (real128, reduced step).")
    contains
        function memory_mb(table, links) result(text)
            type(csv_table_t), intent(in) :: table
            integer, intent(in) :: links
            character(len=:), allocatable :: text
            integer :: row
            text = "—"
            do row = 1, size(table%cells, 2)
                if (field(table, "precision", row) == "real128" .and. field(table, "path", &
                    row) == "reduced" .and. nint(number(table, "links", row)) == links) &
                    text = fixed(number(table, "max_rss_kb", row) / 1024)
            end do
        end function memory_mb
    end subroutine scaling_section

    !> Two tables read as one (the real128 and real64 files of a study); `found` when
    !! either exists.
    subroutine read_both(dir, name, header, table, found)
        character(len=*), intent(in) :: dir, name, header
        type(csv_table_t), intent(out) :: table
        logical, intent(out) :: found
        type(csv_table_t) :: quad, double
        logical :: have_quad, have_double
        type(holosym_status_t) :: status
        call read_csv(dir // "/" // name // ".csv", header, quad, have_quad, status)
        if (.not. status%ok()) have_quad = .false.
        call read_csv(dir // "/" // name // "64.csv", header, double, have_double, status)
        if (.not. status%ok()) have_double = .false.
        found = have_quad .or. have_double
        if (have_quad .and. have_double) then
            table%names = quad%names
            table%cells = reshape([character(len=field_length) :: quad%cells, double%cells], &
                [size(quad%names), size(quad%cells, 2) + size(double%cells, 2)])
        else if (have_quad) then
            table = quad
        else
            table = double
        end if
    end subroutine read_both

    !> The model-file section: each pair's cost against its built-in twin in both
    !! precisions (CPU time and instructions), the chains from model files against K, and
    !! the verdicts.
    subroutine models_section(dir, unit)
        character(len=*), intent(in) :: dir !! directory of the CSV files
        type(output_t), intent(inout) :: unit !! the page
        type(csv_table_t) :: pairs, chains, counts
        logical :: have_pairs, have_chains, have_counts
        character(len=:), allocatable :: line, key
        character(len=field_length), allocatable :: keys(:)
        character(len=7), parameter :: precisions(2) = ["real128", "real64 "]
        real(real64) :: ratio, worst, exponent, load
        integer :: r, k, c, p, met, total
        integer, allocatable :: links(:)
        call unit%line("")
        call unit%line("## Model files against the built-in models")
        call unit%line("")
        call read_both(dir, "models", models_header, pairs, have_pairs)
        call read_both(dir, "model_scaling", model_scaling_header, chains, have_chains)
        call read_both(dir, "model_instructions", model_instructions_header, counts, &
                       have_counts)
        if (.not. (have_pairs .or. have_chains)) then
            call unit%line("No models.csv in " // dir // ": `make bench-models` (`holosym " // &
                "bench --models`) makes it.")
            return
        end if
        call unit%line("The same system as a model file (example/models/, and chains " // &
            "written by tools/chain_model.py) and as the hand-written built-in model, from " // &
            "the same start at the same (M, N, G) and h. CPU: seconds per step, the least " // &
            "of 7 batches of each run in alternation (`holosym bench --models` in the " // &
            "real128 and real64 builds). Instructions: per step under callgrind, exact, " // &
            "through `holosym simulate` with its defaults as a user runs it (" // &
            "`tools/model_instructions.sh`; set-up and parsing excluded by differencing two " // &
            "runs). Both from `make bench-models`. Target: a model file costs at most " // &
            fixed(model_ratio_target) // "x the built-in model, judged on the instruction " // &
            "counts where they were measured (CPU ratios of steps of microseconds vary " // &
            "by tens of percent from run to run on this machine).")
        call unit%line("")
        call unit%line("| system | (M, N, G) | h | real128 built-in s | model s | CPU " // &
            "ratio | instructions ratio | real64 built-in s | model s | CPU ratio | " // &
            "instructions ratio |")
        call unit%line("|---|---|---|---|---|---|---|---|---|---|---|")
        allocate (keys(0))
        met = 0
        total = 0
        worst = 0
        do r = 1, size(pairs%cells, 2)
            key = field(pairs, "model", r) // "," // field(pairs, "M", r) // "," // &
                field(pairs, "N", r) // "," // field(pairs, "G", r)
            if (any(keys == key)) cycle
            keys = [character(len=field_length) :: keys, key]
            line = "| " // field(pairs, "model", r) // " | (" // field(pairs, "M", r) // ", " // &
                field(pairs, "N", r) // ", " // field(pairs, "G", r) // ") | 1/" // &
                int_text(nint(1 / number(pairs, "h", r))) // " |"
            do p = 1, 2
                k = pair_row(pairs, trim(precisions(p)), key)
                c = pair_row(counts, trim(precisions(p)), key)
                if (k == 0) then
                    line = line // " — | — | — | — |"
                    cycle
                end if
                ratio = number(pairs, "ratio", k)
                if (c > 0) ratio = number(counts, "ratio", c)
                total = total + 1
                if (ratio <= model_ratio_target) met = met + 1
                worst = max(worst, ratio)
                line = line // " " // sci(number(pairs, "builtin_seconds_per_step", k)) // &
                    " | " // sci(number(pairs, "model_seconds_per_step", k)) // " | " // &
                    fixed(number(pairs, "ratio", k)) // " |"
                if (c > 0) then
                    line = line // " " // fixed(number(counts, "ratio", c)) // " |"
                else
                    line = line // " — |"
                end if
            end do
            call unit%line(line)
        end do
        call unit%line("")
        if (total > 0) call unit%line("- Model file at most " // fixed(model_ratio_target) // &
            "x the built-in model: met at " // int_text(met) // " of " // int_text(total) // &
            " (system, scheme, precision); largest ratio " // fixed(worst) // trim(merge( &
            " (instructions)", "               ", have_counts)) // ": " // verdict(met == total))
        if (.not. have_chains) return
        call unit%line("")
        call unit%line("Chains of K links from model files (tools/chain_model.py K), (M, N, G) " // &
            "= (4, 3, 5), h = 0.01: seconds per step of the model file and of the built-in " // &
            "chain, and seconds to read, differentiate and compile the file and make its " // &
            "start (load).")
        call unit%line("")
        call unit%line("| K | real128 model s | real128 built-in s | real64 model s | " // &
            "real64 built-in s | load s (real128) |")
        call unit%line("|---|---|---|---|---|---|")
        allocate (links(0))
        do r = 1, size(chains%cells, 2)
            k = nint(number(chains, "links", r))
            if (.not. any(links == k)) links = [links, k]
        end do
        do k = 1, size(links)
            call unit%line("| " // int_text(links(k)) // " | " // &
                cell(per_step(chains, "real128", "model", links(k))) // " | " // &
                cell(per_step(chains, "real128", "builtin", links(k))) // " | " // &
                cell(per_step(chains, "real64", "model", links(k))) // " | " // &
                cell(per_step(chains, "real64", "builtin", links(k))) // " | " // &
                cell(load_time(links(k))) // " |")
        end do
        call unit%line("")
        call read_both(dir, "model_scaling_instructions", model_scaling_instructions_header, &
                       counts, have_counts)
        do p = 1, 2
            exponent = fitted_exponent(chains, trim(precisions(p)), "model")
            line = ""
            if (have_counts) then
                ratio = fitted_exponent(counts, trim(precisions(p)), "model", &
                                        "instructions_per_step")
                if (ratio > 0) then
                    line = "; instructions per step (callgrind, exact): **" // fixed(ratio) // &
                        "**"
                    exponent = ratio
                end if
            end if
            if (exponent > 0) call unit%line("- Fitted exponent of the model-file chain's " // &
                "cost per step against K (K = 8 .. 256), " // trim(precisions(p)) // ": CPU " // &
                fixed(fitted_exponent(chains, trim(precisions(p)), "model")) // line // &
                " (target: at most " // fixed(model_exponent_target) // "): " // &
                verdict(exponent <= model_exponent_target))
        end do
        load = load_time(256)
        if (load >= 0) call unit%line("- Reading, differentiating and compiling the " // &
            "256-link chain's file and making its start: " // fixed(load) // " s (target: " // &
            "under " // fixed(model_load_target) // " s): " // verdict(load < model_load_target))
    contains
        integer function pair_row(table, precision, key) result(row)
            type(csv_table_t), intent(in) :: table
            character(len=*), intent(in) :: precision, key
            integer :: j
            row = 0
            do j = 1, size(table%cells, 2)
                if (field(table, "precision", j) == precision .and. field(table, "model", j) &
                    // "," // field(table, "M", j) // "," // field(table, "N", j) // "," // &
                    field(table, "G", j) == key) then
                    if (column(table, "status") > 0) then
                        if (nint(number(table, "status", j)) /= 0) cycle
                    end if
                    row = j
                end if
            end do
        end function pair_row
        real(real64) function load_time(k) result(seconds)
            integer, intent(in) :: k
            integer :: j
            seconds = -1
            do j = 1, size(chains%cells, 2)
                if (field(chains, "precision", j) == "real128" .and. field(chains, "path", j) &
                    == "model" .and. nint(number(chains, "links", j)) == k) seconds = &
                    number(chains, "load_seconds", j)
            end do
        end function load_time
        function cell(value) result(text)
            real(real64), intent(in) :: value
            character(len=:), allocatable :: text
            text = "—"
            if (value >= 0) text = sci(value)
        end function cell
    end subroutine models_section

    !> The long-run section: per case and target, holosym's and heyoka's cheapest run.
    subroutine long_section(dir, unit)
        character(len=*), intent(in) :: dir !! directory of long.csv
        type(output_t), intent(inout) :: unit !! the page
        type(csv_table_t) :: table
        logical :: found
        real(real64), parameter :: targets(2) = [1.0e-20_real64, 1.0e-24_real64]
        character(len=:), allocatable :: line
        character(len=field_length), allocatable :: cases(:)
        integer :: r, c, t, mine, theirs
        type(holosym_status_t) :: status
        call unit%line("")
        call unit%line("## Long runs")
        call unit%line("")
        call read_csv(dir // "/long.csv", long_header, table, found, status)
        if (.not. (found .and. status%ok())) then
            call unit%line("No long.csv in " // dir // ": `make bench-long` " // &
                "(`holosym bench --long --heyoka PYTHON`) makes it.")
            return
        end if
        call unit%line("real128; the cheapest run of each method with error at T " // &
            "at most the target (holosym: (6,5,7) and (8,7,9), h halved from 1, Newton " // &
            "to the default 8 epsilon; reference: holosym (8,7,9) at h = 1/32, " // &
            "long_reference.csv). max |phi| and the energy error are whole-run " // &
            "(holosym: after every step and at every node; heyoka: on 10001 output times). " // &
            "'x' = heyoka's CPU time / holosym's (target: at least 2, with holosym's " // &
            "max |phi| at most 1e-30).")
        call unit%line("")
        call unit%line("| system | T | target | holosym run | s | error | max phi | " // &
            "energy error | heyoka run | s | error | max phi | energy error | x |")
        call unit%line("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
        allocate (cases(0))
        do r = 1, size(table%cells, 2)
            line = case_of(r)
            if (.not. any(cases == line)) cases = [character(len=field_length) :: cases, line]
        end do
        do c = 1, size(cases)
            do t = 1, size(targets)
                mine = cheapest_long("holosym", trim(cases(c)), targets(t))
                theirs = cheapest_long("heyoka", trim(cases(c)), targets(t))
                call unit%line(case_cells(cases(c), targets(t)) // run_cells(mine) // &
                               run_cells(theirs) // ratio_cell(theirs, mine, mine > 0))
            end do
        end do
        call unit%line("")
        call unit%line("holosym as `holosym simulate --accuracy TARGET --T T` runs it " // &
            "(`init_for_accuracy`: a pilot chooses (M, N, G), h and the Newton tolerance " // &
            "from the request, then the run), against the same heyoka run; 'x' = heyoka's " // &
            "CPU time / holosym's pilot and run together.")
        call unit%line("")
        call unit%line("| system | T | target | plan | pilot + run s | error | max phi | " // &
            "energy error | pilot s | heyoka s | x |")
        call unit%line("|---|---|---|---|---|---|---|---|---|---|---|")
        do c = 1, size(cases)
            do t = 1, size(targets)
                mine = accuracy_long(trim(cases(c)), targets(t))
                if (mine == 0) cycle
                theirs = cheapest_long("heyoka", trim(cases(c)), targets(t))
                line = case_cells(cases(c), targets(t))
                if (nint(number(table, "status", mine)) /= 0) then
                    line = line // " failed (status " // &
                        int_text(nint(number(table, "status", mine))) // ") | — | — | — | — | — |"
                else
                    line = line // run_cells(mine) // " " // &
                        sci(number(table, "compile_seconds", mine)) // " |"
                end if
                if (theirs > 0) then
                    line = line // " " // sci(number(table, "seconds", theirs)) // " |"
                else
                    line = line // " — |"
                end if
                call unit%line(line // ratio_cell(theirs, mine, &
                                                  nint(number(table, "status", mine)) == 0))
            end do
        end do
    contains
        !> The first cells of a case's row: system, T and target.
        function case_cells(case_name, target) result(text)
            character(len=*), intent(in) :: case_name
            real(real64), intent(in) :: target
            character(len=:), allocatable :: text
            text = "| " // field_of(case_name, 1) // " | " // field_of(case_name, 2) // " | " &
                // sci(target) // " |"
        end function case_cells
        !> The cell of heyoka's seconds over holosym's (row `mine`, when `valid`), or "—".
        function ratio_cell(theirs, mine, valid) result(text)
            integer, intent(in) :: theirs, mine
            logical, intent(in) :: valid
            character(len=:), allocatable :: text
            text = " — |"
            if (theirs == 0 .or. .not. valid) return
            text = " " // fixed(number(table, "seconds", theirs) / &
                number(table, "seconds", mine)) // " |"
        end function ratio_cell
        !> The case of a row: its system and T (as a number: the files of holosym and of
        !! heyoka spell T differently).
        function case_of(row) result(text)
            integer, intent(in) :: row
            character(len=:), allocatable :: text
            text = field(table, "system", row) // " " // sci(number(table, "span", row))
        end function case_of
        !> The row through --accuracy of a case and target (0: none).
        integer function accuracy_long(case_name, target) result(found)
            character(len=*), intent(in) :: case_name
            real(real64), intent(in) :: target
            integer :: row
            found = 0
            do row = 1, size(table%cells, 2)
                if (field(table, "method", row) /= "holosym-accuracy" .or. &
                    case_of(row) /= case_name) cycle
                if (abs(number(table, "tolerance", row) - target) <= 1.0e-6_real64 * target) &
                    found = row
            end do
        end function accuracy_long
        integer function cheapest_long(method, case_name, target) result(best)
            character(len=*), intent(in) :: method, case_name
            real(real64), intent(in) :: target
            integer :: row
            best = 0
            do row = 1, size(table%cells, 2)
                if (field(table, "method", row) /= method .or. case_of(row) /= case_name) cycle
                if (nint(number(table, "status", row)) /= 0 .or. &
                    number(table, "error", row) > target) cycle
                if (best == 0) then
                    best = row
                else if (number(table, "seconds", row) < number(table, "seconds", best)) then
                    best = row
                end if
            end do
        end function cheapest_long
        function run_cells(row) result(text)
            integer, intent(in) :: row
            character(len=:), allocatable :: text
            if (row == 0) then
                text = " — | — | — | — | — |"
                return
            end if
            if (field(table, "method", row) == "heyoka") then
                text = " tol " // sci(number(table, "tolerance", row)) // ", " // &
                    field(table, "config", row)
            else
                text = " " // field(table, "config", row)
            end if
            text = text // " | " // sci(number(table, "seconds", row)) // " | " // &
                sci(number(table, "error", row)) // " | " // sci(number(table, "max_phi", row)) &
                // " | " // sci(number(table, "energy_error", row)) // " |"
        end function run_cells
        function field_of(text, k) result(part)
            character(len=*), intent(in) :: text
            integer, intent(in) :: k
            character(len=:), allocatable :: part
            integer :: blank
            blank = index(trim(text), " ")
            if (k == 1) then
                part = text(:blank - 1)
            else
                part = trim(text(blank + 1:))
            end if
        end function field_of
    end subroutine long_section

    pure function verdict(met) result(text)
        logical, intent(in) :: met
        character(len=:), allocatable :: text
        if (met) then
            text = "met."
        else
            text = "**missed**."
        end if
    end function verdict

    pure function int_text(value) result(text)
        integer, intent(in) :: value
        character(len=:), allocatable :: text
        character(len=16) :: buffer
        write (buffer, '(i0)') value
        text = trim(buffer)
    end function int_text

end module holosym_bench_report

!> Holds `not_installed`: fpm installs no module of a source with a submodule.
submodule (holosym_bench_report) holosym_bench_report_app
    implicit none
contains
    module procedure not_installed
    end procedure not_installed
end submodule holosym_bench_report_app
