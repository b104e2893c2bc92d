!> The `extremes` command: numerical stability at the extremes, measured.
!! Six parts: long run (with the growth of round-off), tiny steps, high orders, large
!! steps, stiff springs, near-singular constraints. Markdown to the output unit, progress to
!! the error unit. The studies themselves live in holosym_study_extremes.
module holosym_cli_extremes
    use holosym_kinds, only: wp
    use holosym_status_codes, only: holosym_status_t, int_str, status_code_name, HOLOSYM_SUCCESS
    use holosym_study_extremes, only: extremes_settings_t, extremes_settings, long_run_result_t, &
        run_long_study, growth_result_t, run_growth_study, tiny_cell_t, run_tiny_study, &
        high_order_row_t, run_high_order_study, large_step_cell_t, run_large_step_study, &
        stiff_cell_t, run_stiff_study, near_singular_cell_t, run_near_singular_study, &
        max_study_order, error_floor, paper_step
    use holosym_output, only: output_t
    use holosym_cli_common, only: parsed_command_proceeds, &
        cli_argument_t, split_option, option_value, parse_integer, parse_integer_in, &
        fail, join_lines, EXIT_OK, EXIT_FAILURE
    implicit none
    private

    public :: extremes_options_t, parse_extremes_options, extremes_command, extremes_help
    public :: part_names, short_real

    !> Names of the parts, in report order.
    character(len=*), parameter :: part_names(*) = [character(len=13) :: "long", "tiny", &
        "high", "large", "stiff", "near-singular"]
    !> An error within this many eps sqrt(K) after K steps is round-off: the ulp of the
    !! state (|q| < 1) and of H, times a random walk over the K steps, with margin.
    integer, parameter :: round_off_band = 64
    integer, parameter :: part_long = 1, part_tiny = 2, part_high = 3, part_large = 4, &
                          part_stiff = 5, part_near = 6

    !> Options of `holosym extremes`.
    type :: extremes_options_t
        !> Parts to run (in the order of `part_names`).
        logical :: parts(size(part_names)) = .true.
        !> Sizes of the studies (full or quick, with the overrides applied).
        type(extremes_settings_t) :: settings
        logical :: quick = .false. !! --quick given
        logical :: help = .false.  !! --help given
    end type extremes_options_t

    interface
        !> Does nothing. Its body, in the submodule at the end of this file, keeps this
        !! application module out of `fpm install` (see fpm.toml).
        module subroutine not_installed()
        end subroutine not_installed
    end interface

contains

    !> The text of `holosym extremes --help`.
    pure function extremes_help() result(text)
        character(len=:), allocatable :: text !! the help
        text = join_lines([character(len=96) :: &
            "Usage: holosym extremes [options]", &
            "", &
            "Measure the integrator at the extremes: long runs and round-off growth, tiny", &
            "steps, high orders, large steps, stiff springs, near-singular constraints.", &
            "Markdown on stdout, progress on stderr. The full report takes about a quarter", &
            "of an hour (the long run of 10^6 steps dominates); --quick under a minute.", &
            "", &
            "Options:", &
            "  --part LIST      comma-separated parts: long, tiny, high, large, stiff,", &
            "                   near-singular, or all (default all)", &
            "  --steps N        steps of the long run, 1..2147483647 (default 1000000;", &
            "                   --quick 20000), and the most steps of any run of every", &
            "                   part (the round-off growth runs need N >= 2)", &
            "  --max-order M    largest M of the high-order part, 1..15 (default 15;", &
            "                   --quick 6)", &
            "  --quick          the shortened sizes also run by the test suite", &
            "  --help           this text"])
    end function extremes_help

    !> Parse the options of `extremes`. Failure: HOLOSYM_INVALID_ARGUMENT naming the option
    !! and the value (unknown option or part, missing or malformed value, out of range).
    subroutine parse_extremes_options(args, options, status)
        type(cli_argument_t), intent(in) :: args(:)      !! the command's arguments
        type(extremes_options_t), intent(out) :: options !! parsed settings
        type(holosym_status_t), intent(out) :: status    !! outcome
        character(len=:), allocatable :: name, inline, value
        logical :: has_inline, steps_given, order_given
        integer :: i, steps, max_order

        status%code = HOLOSYM_SUCCESS
        status%message = ""
        steps_given = .false.
        order_given = .false.
        steps = 0
        max_order = 0
        i = 1
        do while (i <= size(args))
            call split_option(args(i)%text, name, inline, has_inline)
            select case (name)
            case ("-h", "--help")
                options%help = .true.
                return
            case ("--quick")
                options%quick = .true.
            case ("--part", "--steps", "--max-order")
                call option_value(args, i, name, inline, has_inline, value, status)
                if (.not. status%ok()) return
                select case (name)
                case ("--part")
                    call parse_parts(value, options%parts, status)
                case ("--steps")
                    call parse_integer_in(name, value, 1, huge(1), steps, status)
                    steps_given = .true.
                case ("--max-order")
                    call parse_integer_in(name, value, 1, max_study_order, max_order, status)
                    order_given = .true.
                end select
                if (.not. status%ok()) return
            case default
                call fail(status, "unknown option '" // args(i)%text // "'")
                return
            end select
            i = i + 1
        end do
        options%settings = extremes_settings(options%quick)
        if (steps_given) then
            ! --steps bounds every run of every part.
            associate (set => options%settings)
                set%max_steps = steps
                set%long_steps = steps
                set%long_window = min(set%long_window, steps)
                set%growth_steps = min(set%growth_steps, steps)
                set%tiny_step_count = min(set%tiny_step_count, steps)
                set%near_steps = min(set%near_steps, steps)
            end associate
        end if
        if (order_given) options%settings%high_max_order = max_order
    end subroutine parse_extremes_options

    !> Parse "long,tiny" or "all" into the part flags.
    subroutine parse_parts(text, parts, status)
        character(len=*), intent(in) :: text
        logical, intent(out) :: parts(:)
        type(holosym_status_t), intent(inout) :: status
        integer :: first, comma, last, k, found
        character(len=:), allocatable :: word
        parts = .false.
        first = 1
        do
            comma = index(text(first:), ",")
            if (comma == 0) then
                last = len(text)
            else
                last = first + comma - 2
            end if
            word = text(first:last)
            if (word == "all") then
                parts = .true.
            else
                found = 0
                do k = 1, size(part_names)
                    if (trim(part_names(k)) == word) found = k
                end do
                if (found == 0 .or. len(word) == 0) then
                    call fail(status, "option --part: unknown part '" // word // "'; choose " &
                        // "from long, tiny, high, large, stiff, near-singular, all")
                    return
                end if
                parts(found) = .true.
            end if
            if (comma == 0) exit
            first = last + 2
        end do
    end subroutine parse_parts

    !> `holosym extremes [options]`: parse, run the selected parts, write Markdown.
    !! Exit 0 success, 1 a study could not run, 2 usage error.
    subroutine extremes_command(args, out, err_unit, exit_code)
        type(cli_argument_t), intent(in) :: args(:) !! the command's arguments
        type(output_t), intent(inout) :: out !! Markdown report
        integer, intent(in) :: err_unit   !! progress and errors
        integer, intent(out) :: exit_code !! process exit code
        type(extremes_options_t) :: options
        type(holosym_status_t) :: status

        call parse_extremes_options(args, options, status)
        if (.not. parsed_command_proceeds("extremes", status, options%help, extremes_help(), &
                                          out, err_unit, exit_code)) return
        if (options%quick) then
            call out%line("# holosym extremes (quick)")
        else
            call out%line("# holosym extremes")
        end if
        call out%line("")
        call out%line("real128: epsilon = " // short_real(epsilon(1.0_wp)) // &
            "; errors at or below " // short_real(error_floor) // " count as round-off.")
        if (options%parts(part_long) .and. status%ok()) &
            call report_long(options%settings, out, err_unit, status)
        if (options%parts(part_tiny) .and. status%ok()) &
            call report_tiny(options%settings, out, err_unit, status)
        if (options%parts(part_high) .and. status%ok()) &
            call report_high(options%settings, out, err_unit, status)
        if (options%parts(part_large) .and. status%ok()) &
            call report_large(options%settings, out, err_unit, status)
        if (options%parts(part_stiff) .and. status%ok()) &
            call report_stiff(options%settings, out, err_unit, status)
        if (options%parts(part_near) .and. status%ok()) &
            call report_near(options%settings, out, status)
        if (.not. status%ok()) then
            write (err_unit, '(a)') "holosym extremes: " // status%message
            exit_code = EXIT_FAILURE
            return
        end if
        exit_code = EXIT_OK
    end subroutine extremes_command

    ! ------------------------------------------------------------------ formatting

    !> A real in short scientific form, e.g. "1.234e-34"; "0" for zero.
    function short_real(value) result(text)
        real(wp), intent(in) :: value !! the number
        character(len=:), allocatable :: text
        character(len=32) :: buffer
        integer :: exponent
        real(wp) :: mantissa
        if (value == 0) then
            text = "0"
            return
        else if (.not. abs(value) <= huge(value)) then
            text = "inf"
            if (value /= value) text = "nan"
            return
        end if
        exponent = floor(log10(abs(value)))
        mantissa = value / 10.0_wp**exponent
        if (abs(mantissa) >= 9.9995_wp) then
            exponent = exponent + 1
            mantissa = mantissa / 10
        end if
        write (buffer, '(f6.3, "e", i0)') mantissa, exponent
        text = trim(adjustl(buffer))
    end function short_real

    !> Fixed text with two decimals.
    function fixed2(value) result(text)
        real(wp), intent(in) :: value
        character(len=:), allocatable :: text
        character(len=32) :: buffer
        write (buffer, '(f0.2)') value
        text = trim(adjustl(buffer))
        if (text(1:1) == ".") text = "0" // text
        if (len(text) >= 2) then
            if (text(1:2) == "-.") text = "-0" // text(2:)
        end if
    end function fixed2

    !> "1/8" for reciprocals of powers of two and small integers, else short_real.
    function step_text(h) result(text)
        real(wp), intent(in) :: h
        character(len=:), allocatable :: text
        real(wp) :: inverse
        ! nint only where it fits the default integer.
        inverse = 1 / h
        text = short_real(h)
        if (h >= 1 .and. h <= huge(1) / 2) then
            if (h == nint(h)) text = int_str(nint(h))
        else if (h < 1 .and. inverse <= huge(1) / 2) then
            if (inverse == nint(inverse)) text = "1/" // int_str(nint(inverse))
        end if
    end function step_text

    !> "success" or the code's name with the code.
    function code_text(code) result(text)
        integer, intent(in) :: code
        character(len=:), allocatable :: text
        if (code == HOLOSYM_SUCCESS) then
            text = "success"
        else
            text = status_code_name(code) // " (" // int_str(code) // ")"
        end if
    end function code_text

    ! ------------------------------------------------------------------ 1. long

    !> Part 1: the long run and the round-off growth ensemble.
    subroutine report_long(settings, out, err_unit, status)
        type(extremes_settings_t), intent(in) :: settings
        type(output_t), intent(inout) :: out
        integer, intent(in) :: err_unit
        type(holosym_status_t), intent(out) :: status
        type(long_run_result_t) :: long
        type(growth_result_t) :: growth
        integer :: k, first
        real(wp) :: centre

        call run_long_study(settings%long_steps, settings%long_window, long, status, err_unit)
        if (.not. status%ok()) return
        call out%line("")
        call out%line("## 1. Long run: spherical pendulum, (M, N, G) = (2, 1, 3), h = 1/8")
        call out%line("")
        call out%line(int_str(long%steps_done) // " of " // int_str(long%steps) // &
            " steps (t = " // short_real(long%steps_done * paper_step) // "), status " // &
            code_text(long%code) // ", " // fixed2(long%iterations) // &
            " Newton iterations per step, " // fixed2(long%seconds) // " s.")
        if (long%code /= HOLOSYM_SUCCESS) call out%line("Message: " // long%message)
        call out%line("")
        call out%line("| quantity | value |")
        call out%line("|---|---|")
        call out%line("| max relative energy error, first " // int_str(long%window) // &
            " steps | " // short_real(long%energy_window) // " |")
        call out%line("| max relative energy error, all " // int_str(long%steps_done) // &
            " steps | " // short_real(long%energy_total) // " |")
        if (long%energy_window > 0) call out%line("| ratio all / first (drift factor) | " &
            // fixed2(long%energy_total / long%energy_window) // " |")
        call out%line("| max abs(phi) at the displacement nodes | " // &
            short_real(long%constraint_max) // " |")
        call out%line("| max abs(Phi H_p) at the step ends | " // &
            short_real(long%velocity_max) // " |")
        call out%line("| growth exponent of the RMS L_z error (blocks below) | " // &
            fixed2(long%lz_exponent) // " |")
        call out%line("")
        call out%line("| steps | max relative energy error | RMS of L_z - L_z(0) |")
        call out%line("|---|---|---|")
        first = 1
        do k = 1, size(long%block_end)
            call out%line("| " // int_str(first) // "-" // int_str(long%block_end(k)) // &
                " | " // short_real(long%block_energy(k)) // " | " // &
                short_real(long%block_lz(k)) // " |")
            first = long%block_end(k) + 1
        end do

        if (settings%growth_steps < 2) then
            ! Bounded by --steps below the two steps a growth fit needs.
            call out%line("")
            call out%line("Round-off growth: not run (--steps " // &
                int_str(settings%growth_steps) // " < 2).")
            return
        end if
        call run_growth_study(settings%growth_steps, settings%growth_realizations, growth, &
                              status, err_unit)
        if (.not. status%ok()) return
        call out%line("")
        call out%line("### Round-off growth: L_z with compensated and naive summation")
        call out%line("")
        call out%line("L_z = x p_y - y p_x is conserved exactly by the scheme, so its " // &
            "change is round-off alone, at h = 1/8 as at any h. RMS over " // &
            int_str(growth%realizations) // " copies of the start state rotated about z and " &
            // "over the steps of each block, on the default (reduced) path with `integrate` " &
            // "(compensated) and with a loop of `step` (naive), and on the general path " // &
            "(`structured = .false.`) with `integrate`; " // int_str(growth%steps) // &
            " steps, " // fixed2(growth%seconds) // " s, status " // code_text(growth%code) // ".")
        call out%line("")
        call out%line("| steps | RMS, compensated (integrate) | RMS, naive (step loop) " &
            // "| RMS, general path (integrate) | compensated / (eps sqrt(k)) | " // &
            "naive / (eps sqrt(k)) | general / (eps sqrt(k)) |")
        call out%line("|---|---|---|---|---|---|---|")
        first = 1
        do k = 1, size(growth%block_end)
            centre = epsilon(1.0_wp) * sqrt((real(first, wp) + growth%block_end(k)) / 2)
            call out%line("| " // int_str(first) // "-" // int_str(growth%block_end(k)) &
                // " | " // short_real(growth%rms_compensated(k)) // " | " // &
                short_real(growth%rms_naive(k)) // " | " // &
                short_real(growth%rms_general(k)) // " | " // &
                fixed2(growth%rms_compensated(k) / centre) // " | " // &
                fixed2(growth%rms_naive(k) / centre) // " | " // &
                fixed2(growth%rms_general(k) / centre) // " |")
            first = growth%block_end(k) + 1
        end do
        call out%line("")
        call out%line("Fitted growth exponent (blocks from step 16 on; 1/2 = random " // &
            "walk, 1 = drift): compensated " // fixed2(growth%exponent_compensated) // &
            ", naive " // fixed2(growth%exponent_naive) // ", general path " // &
            fixed2(growth%exponent_general) // ".")
    end subroutine report_long

    ! ------------------------------------------------------------------ 2. tiny

    !> Part 2: tiny steps.
    subroutine report_tiny(settings, out, err_unit, status)
        type(extremes_settings_t), intent(in) :: settings
        type(output_t), intent(inout) :: out
        integer, intent(in) :: err_unit
        type(holosym_status_t), intent(out) :: status
        type(tiny_cell_t), allocatable :: cells(:, :)
        character(len=:), allocatable :: line
        integer :: i, j, which
        real(wp) :: band

        call run_tiny_study(settings%tiny_orders, settings%tiny_steps, &
                            settings%tiny_step_count, cells, status, err_unit)
        if (.not. status%ok()) return
        band = round_off_band * epsilon(1.0_wp) * sqrt(real(settings%tiny_step_count, wp))
        call out%line("")
        call out%line("## 2. Tiny steps: spherical pendulum, " // &
            int_str(settings%tiny_step_count) // " steps per run, N = M - 1, G = M + 1")
        call out%line("")
        call out%line("Global error: max abs(q(K h) - q_ref) against M = 8 with steps " &
            // "<= 1/16 (the reference changes by at most " // &
            short_real(maxval(cells%reference_change)) // " between steps <= 1/8 and <= 1/16)." &
            // " Round-off alone gives about eps sqrt(K) = " // &
            short_real(epsilon(1.0_wp) * sqrt(real(settings%tiny_step_count, wp))) // ".")
        do which = 1, 2
            call out%line("")
            if (which == 1) then
                call out%line("Global error of q:")
            else
                call out%line("Max relative energy error:")
            end if
            call out%line("")
            line = "| h |"
            do j = 1, size(cells, 2)
                line = line // " M = " // int_str(cells(1, j)%order_m) // " (order " // &
                    int_str(2 * cells(1, j)%order_m) // ") |"
            end do
            call out%line(line)
            call out%line("|---|" // repeat("---|", size(cells, 2)))
            do i = 1, size(cells, 1)
                line = "| " // short_real(cells(i, 1)%h) // " |"
                do j = 1, size(cells, 2)
                    if (cells(i, j)%code /= HOLOSYM_SUCCESS) then
                        line = line // " " // code_text(cells(i, j)%code) // " |"
                    else if (which == 1) then
                        line = line // " " // short_real(cells(i, j)%global_error) // " |"
                    else
                        line = line // " " // short_real(cells(i, j)%energy_error) // " |"
                    end if
                end do
                call out%line(line)
            end do
        end do
        call out%line("")
        call out%line("Where the error turns from truncation to round-off: the smallest " &
            // "h whose error is still above the round-off band (" // &
            int_str(round_off_band) // " eps sqrt(K) = " // short_real(band) // &
            ", the ulp of the state and of H over a random walk of K steps), and the " // &
            "largest h inside it:")
        call out%line("")
        do which = 1, 2
            do j = 1, size(cells, 2)
                call turn_text(cells(:, j), which == 1, band, line)
                call out%line("- " // merge("global error", "energy error", which == 1) &
                    // ", M = " // int_str(cells(1, j)%order_m) // ": " // line)
            end do
        end do
    end subroutine report_tiny

    !> Where a column of the tiny-step table turns: last h above `band`, first h within it.
    subroutine turn_text(column, global, band, text)
        type(tiny_cell_t), intent(in) :: column(:)
        logical, intent(in) :: global
        real(wp), intent(in) :: band
        character(len=:), allocatable, intent(out) :: text
        real(wp) :: error
        integer :: i, above, within
        above = 0
        within = 0
        do i = 1, size(column)
            if (column(i)%code /= HOLOSYM_SUCCESS) cycle
            error = column(i)%energy_error
            if (global) error = column(i)%global_error
            if (error > band) then
                above = i
            else if (within == 0) then
                within = i
            end if
        end do
        text = ""
        if (above > 0) then
            error = column(above)%energy_error
            if (global) error = column(above)%global_error
            text = "truncation down to h = " // short_real(column(above)%h) // " (error " // &
                short_real(error) // ")"
        end if
        if (within > 0) then
            error = column(within)%energy_error
            if (global) error = column(within)%global_error
            if (len(text) > 0) text = text // "; "
            text = text // "round-off from h = " // short_real(column(within)%h) // &
                " (error " // short_real(error) // ")"
        else
            text = text // "; no turn above h = " // short_real(column(size(column))%h)
        end if
    end subroutine turn_text

    ! ------------------------------------------------------------------ 3. high

    !> Part 3: high orders.
    subroutine report_high(settings, out, err_unit, status)
        type(extremes_settings_t), intent(in) :: settings
        type(output_t), intent(inout) :: out
        integer, intent(in) :: err_unit
        type(holosym_status_t), intent(out) :: status
        type(high_order_row_t), allocatable :: rows(:)
        character(len=:), allocatable :: line
        integer :: i, k

        call run_high_order_study(settings%high_max_order, settings%high_steps, &
                                  settings%high_span, rows, status, err_unit, settings%max_steps)
        if (.not. status%ok()) return
        call out%line("")
        call out%line("## 3. High orders: N = M - 1, G = M + 1, spherical pendulum")
        call out%line("")
        call out%line("Quadrature: max error on monomials of the exact degrees (Gauss " // &
            "G points: 2G-1; Lobatto M+1 points: 2M-1). Basis: interpolated tau^k and " // &
            "k tau^(k-1), k <= M, at the Gauss points. Conditioning: first step, h = 1/8, " // &
            "row-equilibrated Newton Jacobian at the solution.")
        call out%line("")
        call out%line("| M | G | Gauss error | Lobatto error | basis error | " // &
            "smallest pivot ratio | 1-norm condition | Newton iterations |")
        call out%line("|---|---|---|---|---|---|---|---|")
        do i = 1, size(rows)
            call out%line("| " // int_str(rows(i)%order_m) // " | " // &
                int_str(rows(i)%gauss_points) // " | " // short_real(rows(i)%gauss_error) // &
                " | " // short_real(rows(i)%lobatto_error) // " | " // &
                short_real(rows(i)%basis_error) // " | " // short_real(rows(i)%pivot_ratio) // &
                " | " // short_real(rows(i)%condition) // " | " // &
                int_str(rows(i)%newton_iterations) // " |")
        end do
        call out%line("")
        call out%line("Max relative energy error over T = " // fixed2(settings%high_span) &
            // "; refinement stops at the floor " // short_real(error_floor) // ":")
        call out%line("")
        line = "| M | law 2M |"
        do k = 1, size(settings%high_steps)
            line = line // " h = " // step_text(settings%high_steps(k)) // " |"
        end do
        call out%line(line // " observed order |")
        call out%line("|---|---|" // repeat("---|", size(settings%high_steps) + 1))
        do i = 1, size(rows)
            line = "| " // int_str(rows(i)%order_m) // " | " // int_str(2 * rows(i)%order_m) &
                // " |"
            do k = 1, size(settings%high_steps)
                if (.not. rows(i)%ran(k)) then
                    line = line // " - |"
                else if (rows(i)%codes(k) /= HOLOSYM_SUCCESS) then
                    line = line // " " // code_text(rows(i)%codes(k)) // " |"
                else
                    line = line // " " // short_real(rows(i)%energy_error(k)) // " |"
                end if
            end do
            if (rows(i)%order_measured) then
                line = line // " " // fixed2(rows(i)%order) // " (" // &
                    step_text(rows(i)%order_h(1)) // ", " // step_text(rows(i)%order_h(2)) // ") |"
            else
                line = line // " at floor |"
            end if
            call out%line(line)
        end do
    end subroutine report_high

    ! ------------------------------------------------------------------ 4. large

    !> Part 4: large steps.
    subroutine report_large(settings, out, err_unit, status)
        type(extremes_settings_t), intent(in) :: settings
        type(output_t), intent(inout) :: out
        integer, intent(in) :: err_unit
        type(holosym_status_t), intent(out) :: status
        type(large_step_cell_t), allocatable :: cells(:)
        integer :: i

        call run_large_step_study(settings%large_max_order, cells, status, err_unit, &
                                  settings%max_steps)
        if (.not. status%ok()) return
        call out%line("")
        call out%line("## 4. Large steps: N = M - 1, G = M + 1, from the paper's states")
        call out%line("")
        call out%line("Largest h found (doubling from 1/8, then 12 bisections) for " // &
            "which the first step converges, and for which a run over T = 10 completes; " // &
            "the status just above it, and whether that failure is clean (positive code; " // &
            "state unchanged after a failed first step, finite and on the manifold after a " // &
            "failed run).")
        call out%line("")
        call out%line("| system | M | h, first step | failure above | clean | " // &
            "h, run T = 10 | failure above | clean | energy error at h |")
        call out%line("|---|---|---|---|---|---|---|---|---|")
        do i = 1, size(cells)
            call out%line("| " // cells(i)%system // " | " // int_str(cells(i)%order_m) &
                // " | " // short_real(cells(i)%h_step) // " | " // &
                failure_text(cells(i)%step_fail_code, cells(i)%h_step_fail) // " | " // &
                trim(merge("yes", "no ", cells(i)%step_fail_clean)) // " | " // &
                short_real(cells(i)%h_run) // " | " // &
                failure_text(cells(i)%run_fail_code, cells(i)%h_run_fail) // &
                steps_text(cells(i)%run_fail_code, cells(i)%run_fail_steps) // " | " // &
                trim(merge("yes", "no ", cells(i)%run_fail_clean)) // " | " // &
                short_real(cells(i)%run_energy_error) // " |")
        end do
    end subroutine report_large

    !> " after 3 steps" for a failure, "" otherwise.
    function steps_text(code, steps) result(text)
        integer, intent(in) :: code, steps
        character(len=:), allocatable :: text
        text = ""
        if (code /= HOLOSYM_SUCCESS) text = " after " // int_str(steps) // " steps"
    end function steps_text

    !> "Newton diverged (3) at 2.5", or "none up to the cap" when nothing failed.
    function failure_text(code, h) result(text)
        integer, intent(in) :: code
        real(wp), intent(in) :: h
        character(len=:), allocatable :: text
        if (code == HOLOSYM_SUCCESS) then
            text = "none up to h = 64"
        else
            text = code_text(code) // " at " // short_real(h)
        end if
    end function failure_text

    ! ------------------------------------------------------------------ 5. stiff

    !> Part 5: stiff springs.
    subroutine report_stiff(settings, out, err_unit, status)
        type(extremes_settings_t), intent(in) :: settings
        type(output_t), intent(inout) :: out
        integer, intent(in) :: err_unit
        type(holosym_status_t), intent(out) :: status
        type(stiff_cell_t), allocatable :: cells(:)
        integer :: i

        call run_stiff_study(settings%stiffnesses, settings%stiff_orders, &
                             settings%stiff_omega_h, settings%stiff_periods, cells, status, &
                             err_unit, settings%max_steps)
        if (.not. status%ok()) return
        call out%line("")
        call out%line("## 5. Stiff springs: spring-linkage from the paper's state, " // &
            fixed2(settings%stiff_periods) // " spring periods 2 pi / omega, omega = sqrt(k/m_r)")
        call out%line("")
        call out%line("| k | (M, N, G) | omega h | h | steps done | status | " // &
            "max relative energy error | max abs(phi) | Newton iterations per step |")
        call out%line("|---|---|---|---|---|---|---|---|---|")
        do i = 1, size(cells)
            call out%line("| " // short_real(cells(i)%stiffness) // " | (" // &
                int_str(cells(i)%order_m) // ", " // int_str(cells(i)%order_n) // ", " // &
                int_str(cells(i)%gauss_points) // ") | " // step_text(cells(i)%omega_h) // &
                " | " // short_real(cells(i)%h) // " | " // int_str(cells(i)%steps_done) // &
                "/" // int_str(cells(i)%steps) // " | " // code_text(cells(i)%code) // " | " &
                // short_real(cells(i)%energy_error) // " | " // &
                short_real(cells(i)%constraint_max) // " | " // fixed2(cells(i)%iterations) // &
                " |")
        end do
    end subroutine report_stiff

    ! ------------------------------------------------------------------ 6. near-singular

    !> Part 6: near-singular constraints.
    subroutine report_near(settings, out, status)
        type(extremes_settings_t), intent(in) :: settings
        type(output_t), intent(inout) :: out
        type(holosym_status_t), intent(out) :: status
        type(near_singular_cell_t), allocatable :: cells(:)
        integer :: i

        call run_near_singular_study(settings%deltas, settings%near_steps, &
                                     settings%near_step, cells, status)
        if (.not. status%ok()) return
        call out%line("")
        call out%line("## 6. Near-singular constraints: linkage with rod L = 2R(1 + delta)")
        call out%line("")
        call out%line("Start at rest, ball 1 at the bottom of track 1, ball 2 at the " // &
            "top of track 2, rod almost perpendicular to the springs; at delta = 0 the three " &
            // "constraint gradients are dependent. Projected onto the manifold, then " // &
            int_str(settings%near_steps) // " steps of h = " // step_text(settings%near_step) &
            // " with (2, 1, 3).")
        call out%line("")
        call out%line("| delta | smallest pivot ratio of Phi Phi^T | status | steps " // &
            "done | max abs(lambda) | smallest Newton pivot ratio | max abs(phi) | " // &
            "max relative energy error |")
        call out%line("|---|---|---|---|---|---|---|---|")
        do i = 1, size(cells)
            call out%line("| " // short_real(cells(i)%delta) // " | " // &
                short_real(cells(i)%gram_pivot) // " | " // code_text(cells(i)%code) // " | " &
                // int_str(cells(i)%steps_done) // " | " // short_real(cells(i)%lambda_max) // &
                " | " // short_real(cells(i)%newton_pivot) // " | " // &
                short_real(cells(i)%constraint_max) // " | " // &
                short_real(cells(i)%energy_error) // " |")
        end do
        call out%line("")
        call out%line("Messages of the failed runs:")
        call out%line("")
        do i = 1, size(cells)
            if (cells(i)%code /= HOLOSYM_SUCCESS) call out%line("- delta = " // &
                short_real(cells(i)%delta) // ": " // cells(i)%message)
        end do
    end subroutine report_near

end module holosym_cli_extremes

!> Holds `not_installed`: fpm installs no module of a source with a submodule.
submodule (holosym_cli_extremes) holosym_cli_extremes_app
    implicit none
contains
    module procedure not_installed
    end procedure not_installed
end submodule holosym_cli_extremes_app
