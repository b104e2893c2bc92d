!> Sections of docs/performance.md from the CSV files of `holosym bench --scaling`
!! (DIR/scaling.csv, scaling64.csv) and `--long` (DIR/long.csv): tables, the fitted
!! exponent of the cost per step against K, and the verdicts on the scaling and long-run
!! targets. Missing files give a line saying which command makes them.
module holosym_bench_report
    use, intrinsic :: iso_fortran_env, only: real64
    use holosym_output, only: output_t
    implicit none
    private

    public :: scaling_section, long_section, read_csv, csv_table_t

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

    !> Read a CSV file with a header line; `found` false when the file is missing or has a
    !! line with another number of fields than the header.
    subroutine read_csv(path, table, found)
        character(len=*), intent(in) :: path      !! the file
        type(csv_table_t), intent(out) :: table   !! its contents
        logical, intent(out) :: found             !! read
        character(len=2048) :: line
        character(len=field_length), allocatable :: fields(:)
        integer :: unit, ios, rows
        inquire (file=path, exist=found)
        if (.not. found) return
        open (newunit=unit, file=path, status="old", action="read", iostat=ios)
        found = ios == 0
        if (.not. found) return
        read (unit, '(a)', iostat=ios) line
        if (ios /= 0) then
            found = .false.
            close (unit)
            return
        end if
        table%names = split(line)
        allocate (table%cells(size(table%names), 0))
        rows = 0
        do
            read (unit, '(a)', iostat=ios) line
            if (ios /= 0) exit
            if (len_trim(line) == 0) cycle
            fields = split(line)
            if (size(fields) /= size(table%names)) then
                found = .false.
                exit
            end if
            table%cells = reshape([character(len=field_length) :: table%cells, fields], &
                [size(table%names), rows + 1])
            rows = rows + 1
        end do
        close (unit)
    end subroutine read_csv

    !> The comma-separated fields of a line.
    pure function split(line) result(fields)
        character(len=*), intent(in) :: line
        character(len=field_length), allocatable :: fields(:)
        integer :: first, comma
        allocate (fields(0))
        first = 1
        do
            comma = index(line(first:), ",")
            if (comma == 0) then
                fields = [character(len=field_length) :: fields, line(first:len_trim(line))]
                exit
            end if
            fields = [character(len=field_length) :: fields, line(first:first + comma - 2)]
            first = first + comma
        end do
    end function split

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
    real(real64) function fitted_exponent(table, precision, path) result(slope)
        type(csv_table_t), intent(in) :: table
        character(len=*), intent(in) :: precision, path
        real(real64) :: x(size(table%cells, 2)), y(size(table%cells, 2))
        integer :: r, count, links
        count = 0
        do r = 1, size(table%cells, 2)
            links = nint(number(table, "links", r))
            if (field(table, "precision", r) /= precision .or. field(table, "path", r) /= path &
                .or. links < 8 .or. links > 256 .or. nint(number(table, "status", r)) /= 0) cycle
            count = count + 1
            x(count) = log(real(links, real64))
            y(count) = log(number(table, "seconds_per_step", r))
        end do
        slope = -1
        if (count < 2) return
        slope = sum((x(:count) - sum(x(:count)) / count) * (y(:count) - sum(y(:count)) / count)) &
            / sum((x(:count) - sum(x(:count)) / count)**2)
    end function fitted_exponent

    !> The scaling section: table, exponents, memory per link, verdicts.
    subroutine scaling_section(dir, unit)
        character(len=*), intent(in) :: dir !! directory of the CSV files
        type(output_t), intent(inout) :: unit !! the page
        type(csv_table_t) :: quad, double, both
        logical :: have_quad, have_double
        integer :: r, links, k
        integer, allocatable :: all_links(:)
        real(real64) :: values(4), rss_first, rss_last, exponent, at100(2)
        character(len=:), allocatable :: line
        character(len=7), parameter :: precisions(2) = ["real128", "real64 "]
        character(len=7), parameter :: paths(2) = ["reduced", "general"]
        call unit%line("")
        call unit%line("## Scaling: a chain of K planar pendula")
        call unit%line("")
        call read_csv(dir // "/scaling.csv", quad, have_quad)
        call read_csv(dir // "/scaling64.csv", double, have_double)
        if (.not. (have_quad .or. have_double)) then
            call unit%line("No scaling.csv in " // dir // ": `holosym bench --scaling` " // &
                "makes it.")
            return
        end if
        if (.not. have_quad) quad = double
        if (.not. have_double) double = quad
        both%names = quad%names
        both%cells = reshape([character(len=field_length) :: quad%cells, double%cells], [ &
            size(quad%names), &
            size(quad%cells, 2) + size(double%cells, 2)])
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
        call unit%line("")
        call unit%line("## Long runs")
        call unit%line("")
        call read_csv(dir // "/long.csv", table, found)
        if (.not. found) then
            call unit%line("No long.csv in " // dir // ": `make bench-long` " // &
                "(`holosym bench --long --heyoka PYTHON`) makes it.")
            return
        end if
        call unit%line("real128; the cheapest run of each method with error at T " // &
            "at most the target (reference: holosym (8,7,9) at h = 1/32, " // &
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
            line = field(table, "system", r) // " " // field(table, "span", r)
            if (.not. any(cases == line)) cases = [character(len=field_length) :: cases, line]
        end do
        do c = 1, size(cases)
            do t = 1, size(targets)
                mine = cheapest_long("holosym", trim(cases(c)), targets(t))
                theirs = cheapest_long("heyoka", trim(cases(c)), targets(t))
                line = "| " // field_of(cases(c), 1) // " | " // field_of(cases(c), 2) // &
                    " | " // sci(targets(t)) // " | " // run_cells(mine) // run_cells(theirs)
                if (mine > 0 .and. theirs > 0) then
                    line = line // " " // fixed(number(table, "seconds", theirs) / &
                        number(table, "seconds", mine)) // " |"
                else
                    line = line // " — |"
                end if
                call unit%line(line)
            end do
        end do
    contains
        integer function cheapest_long(method, case_name, target) result(best)
            character(len=*), intent(in) :: method, case_name
            real(real64), intent(in) :: target
            integer :: row
            best = 0
            do row = 1, size(table%cells, 2)
                if (field(table, "method", row) /= method .or. field(table, "system", row) // &
                    " " // field(table, "span", row) /= case_name) cycle
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
                text = "— | — | — | — | — |"
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
