!> The `poincare` command of the `holosym` tool: the crossings of a section g(q, p) = 0
!! by one or many orbits of a system, as CSV (orbit, t, q1..qn, p1..pn), the orbits
!! integrated in parallel on the farm of `ensemble` (OpenMP threads; MPI ranks in the
!! holosym-mpi build).
!!
!! The work is the library's (`make_section`, `run_ensemble` with a section); this module
!! parses the options, builds the states, writes the crossings in the order of the orbits'
!! ids (the file is the same whatever the threads or ranks) and reports.
module holosym_cli_poincare
    use, intrinsic :: iso_fortran_env, only: int64
    use holosym_kinds, only: wp
    use holosym_status_codes, only: holosym_status_t, status_code_name, int_str, real_str, &
        append_numbered, HOLOSYM_SUCCESS
    use holosym_problem, only: constrained_hamiltonian
    use holosym_events, only: EVENT_ANY, EVENT_RISING, EVENT_FALLING
    use holosym_sections, only: section_t, make_section
    use holosym_task_farm, only: task_farm, openmp_farm
    use holosym_ensemble, only: ensemble_settings_t, ensemble_states_t, ensemble_result_t, &
        run_ensemble, check_ensemble, perturbed_states, sorted_order
    use holosym_ensemble_files, only: read_ensemble_states, seconds_text
    use holosym_systems, only: system_source_t, make_source_system
    use holosym_cli_common, only: parsed_command_proceeds, cli_argument_t, split_option, &
        option_value, parse_integer_in, fail, csv_real, join_lines, default_orders, EXIT_OK, &
        EXIT_FAILURE
    use holosym_cli_ensemble, only: ensemble_config_t, workers_text, perturb_options_help, &
        system_options_help, take_run_option
    use holosym_output, only: output_t, open_output, same_file
    implicit none
    private

    public :: poincare_command, poincare_help

    !> Largest --count.
    integer, parameter :: max_count = 1000000
    !> Default --T: long enough for a section of a pendulum-like system to collect points.
    real(wp), parameter :: default_span = 100

    !> Options of `holosym poincare`: those it shares with `ensemble` (the system, the
    !! scheme, h, T, the states, the output, threads, --project, --quiet) and the section.
    type :: poincare_config_t
        type(ensemble_config_t) :: orbits        !! the shared options (T default 100)
        character(len=:), allocatable :: section !! g(q, p)
        integer :: direction = EVENT_RISING      !! crossings wanted
        integer :: count = 0                     !! crossings per orbit (0: up to T)
    end type poincare_config_t

    interface
        !> Does nothing. Its body, in the submodule at the end of this file, keeps this
        !! application module out of `fpm install` (see fpm.toml).
        module subroutine not_installed()
        end subroutine not_installed
    end interface

contains

    !> The text of `holosym poincare --help`.
    pure function poincare_help() result(text)
        character(len=:), allocatable :: text !! the help
        text = join_lines([character(len=96) :: &
            "Usage: holosym poincare --section EXPR [options]", &
            "", &
            "The crossings of the section EXPR = 0 by orbits of a system (a Poincare", &
            "section), located within the steps to the accuracy of the scheme's steps", &
            "(docs/events.md), written as CSV rows orbit,t,q1..qn,p1..pn in the order of", &
            "the orbits' ids: the same file whatever the threads or MPI ranks.", &
            "", &
            "Section:", &
            "  --section EXPR  g(q, p), the grammar of model files over q1..qn, p1..pn", &
            "                  (and a model's own names), e.g. 'q3 - 0.75'", &
            "  --direction D   rising (g from - to +), falling or any      [rising]", &
            "  --count K       end each orbit at its K-th crossing, 1 to 1000000 [up to T]", &
            "", &
            "Orbits (the system's initial state alone, or one of):", &
            "  --states FILE   CSV rows id,q1..qn,p1..pn[,h][,T] as for ensemble", &
            perturb_options_help(), &
            "  --project       project off-manifold --states rows onto the manifold", &
            "", &
            "Options:", &
            system_options_help(), &
            "  --h REAL        step size                                    [0.0625]", &
            "  --T REAL        final time of each orbit                     [100]", &
            "  --output FILE   the crossings CSV                            [standard output]", &
            "  --threads N     OpenMP threads, 1..256                       [OMP_NUM_THREADS]", &
            "  --quiet         no start and summary lines", &
            "  -h, --help      show this help", &
            "", &
            "An orbit that fails keeps the crossings found before (its message on stderr).", &
            "Exit status: 0 every orbit ran and the section was crossed; 1 an orbit failed,", &
            "no orbit crossed the section, bad input or an I/O failure; 2 bad usage.", &
            "", &
            "Example:", &
            "  holosym poincare --system pendulum --section 'q3 - 0.75' --direction rising \", &
            "      --T 10 --M 8 --h 1/8 --output s.csv"])
    end function poincare_help

    !> Run `holosym poincare` with its arguments.
    subroutine poincare_command(args, out, err_unit, exit_code, farm)
        type(cli_argument_t), intent(in) :: args(:) !! arguments after "poincare"
        type(output_t), intent(inout) :: out !! the help and, without --output, the CSV
        integer, intent(in) :: err_unit   !! unit for messages
        integer, intent(out) :: exit_code !! process exit code
        class(task_farm), intent(inout), optional :: farm !! who computes (MPI: every rank)
        type(poincare_config_t) :: config
        type(holosym_status_t) :: status
        type(openmp_farm) :: threads
        call parse_poincare_options(args, config, status)
        if (.not. parsed_command_proceeds("poincare", status, config%orbits%help, &
                                          poincare_help(), out, err_unit, exit_code)) return
        threads%threads = config%orbits%threads
        if (present(farm)) then
            call run_poincare_command(config, farm, out, err_unit, exit_code)
        else
            call run_poincare_command(config, threads, out, err_unit, exit_code)
        end if
    end subroutine poincare_command

    !> Parse the options of `poincare`. Failure: HOLOSYM_INVALID_ARGUMENT naming the option.
    subroutine parse_poincare_options(args, config, status)
        type(cli_argument_t), intent(in) :: args(:)
        type(poincare_config_t), intent(out) :: config
        type(holosym_status_t), intent(out) :: status
        character(len=:), allocatable :: name, inline, value
        logical :: has_inline, n_given, g_given, taken
        integer :: i
        config%section = ""
        config%orbits%states = ""
        config%orbits%output = ""
        config%orbits%final_time = default_span
        status%code = HOLOSYM_SUCCESS
        status%message = ""
        n_given = .false.
        g_given = .false.
        i = 1
        do while (i <= size(args))
            call split_option(args(i)%text, name, inline, has_inline)
            select case (name)
            case ("-h", "--help")
                config%orbits%help = .true.
                return
            case ("--project", "--quiet")
                if (has_inline) then
                    call fail(status, "option " // name // " takes no value")
                    return
                end if
                if (name == "--project") config%orbits%project = .true.
                if (name == "--quiet") config%orbits%quiet = .true.
            case ("--system", "--model", "--set", "--links", "--M", "--N", "--G", "--h", &
                  "--T", "--states", "--perturb", "--scale", "--seed", "--output", &
                  "--threads", "--section", "--direction", "--count")
                call option_value(args, i, name, inline, has_inline, value, status)
                if (.not. status%ok()) return
                call config%orbits%source%take(name, value, taken, status)
                if (status%ok() .and. .not. taken) call take_section_option(name, value, &
                                                                            config, status)
                if (status%ok() .and. .not. taken) call take_run_option(name, value, &
                    config%orbits, taken, n_given, g_given, status)
                if (.not. status%ok()) return
            case default
                call fail(status, "unknown option '" // args(i)%text // "'")
                return
            end select
            i = i + 1
        end do
        call config%orbits%source%check(status)
        if (.not. status%ok()) return
        call default_orders(config%orbits%order_m, config%orbits%order_n, &
                            config%orbits%gauss_points, n_given, g_given, status)
        if (.not. status%ok()) return
        call check_poincare_options(config, status)
    end subroutine parse_poincare_options

    !> --section, --direction, --count into `config`.
    subroutine take_section_option(name, value, config, status)
        character(len=*), intent(in) :: name, value
        type(poincare_config_t), intent(inout) :: config
        type(holosym_status_t), intent(inout) :: status
        select case (name)
        case ("--section")
            config%section = value
        case ("--direction")
            select case (value)
            case ("rising")
                config%direction = EVENT_RISING
            case ("falling")
                config%direction = EVENT_FALLING
            case ("any")
                config%direction = EVENT_ANY
            case default
                call fail(status, "option --direction must be rising, falling or any; " // &
                    "got '" // value // "'")
            end select
        case ("--count")
            call parse_integer_in(name, value, 1, max_count, config%count, status)
        end select
    end subroutine take_section_option

    !> The options together: a section, at most one source of states, T > 0 and T/h in
    !! range, --states and --output different files.
    subroutine check_poincare_options(config, status)
        type(poincare_config_t), intent(in) :: config
        type(holosym_status_t), intent(inout) :: status
        associate (o => config%orbits)
            if (len_trim(config%section) == 0) then
                call fail(status, "option --section EXPR is required (g(q, p) over q1..qn, " &
                    // "p1..pn, e.g. --section 'q1')")
            else if (len(o%states) > 0 .and. o%perturb > 0) then
                call fail(status, "give at most one of --states FILE and --perturb K")
            else if (.not. (o%final_time > 0)) then
                call fail(status, "option --T must be > 0")
            else if (o%final_time / o%step_size > real(huge(1), wp)) then
                call fail(status, "options --T and --h: T/h must give at most " // &
                    int_str(huge(1)) // " steps")
            else if (len(o%states) > 0 .and. len(o%output) > 0) then
                if (same_file(o%states, o%output)) call fail(status, "options --states " // &
                    "and --output name the same file; give each its own")
            end if
        end associate
    end subroutine check_poincare_options

    !> Run a parsed `poincare` command on a farm.
    subroutine run_poincare_command(config, farm, out, err_unit, exit_code)
        type(poincare_config_t), intent(in) :: config
        class(task_farm), intent(inout) :: farm
        type(output_t), intent(inout) :: out
        integer, intent(in) :: err_unit
        integer, intent(out) :: exit_code
        class(constrained_hamiltonian), allocatable :: sys
        type(section_t), target :: section
        type(ensemble_states_t) :: states
        type(ensemble_settings_t) :: settings
        type(ensemble_result_t), allocatable :: results(:)
        type(holosym_status_t) :: status
        real(wp), allocatable :: q0(:), p0(:)
        character(len=:), allocatable :: note
        integer(int64) :: clock_start, clock_end, clock_rate
        logical :: collector
        exit_code = EXIT_FAILURE
        collector = farm%is_collector()
        call system_clock(clock_start, clock_rate)
        call make_source_system(config%orbits%source, sys, q0, p0, status, note)
        if (status%ok() .and. len(note) > 0 .and. collector .and. .not. config%orbits%quiet) &
            write (err_unit, '(a)') "holosym poincare: note: " // note
        if (status%ok()) call make_section(sys, config%section, config%direction, section, &
                                           status)
        if (status%ok()) call orbit_states(config, q0, p0, sys%n, states, status)
        settings%order_m = config%orbits%order_m
        settings%order_n = config%orbits%order_n
        settings%gauss_points = config%orbits%gauss_points
        settings%step_size = config%orbits%step_size
        settings%final_time = config%orbits%final_time
        settings%project = config%orbits%project .or. config%orbits%perturb > 0
        settings%section => section
        settings%crossing_limit = config%count
        if (status%ok()) call check_ensemble(sys, states, settings, status)
        if (.not. farm%agree(status%ok())) then
            if (.not. status%ok()) write (err_unit, '(a)') "holosym poincare: error: " // &
                status%message
            return
        end if
        if (collector .and. .not. config%orbits%quiet) write (err_unit, '(a)') &
            "holosym poincare: " // config%orbits%source%label() // " (n = " // int_str(sys%n) // &
            ", m = " // int_str(sys%m) // "), section " // config%section // " = 0 " // &
            trim(direction_name(config%direction)) // ", " // &
            plural(size(states%id), "orbit") // " to T = " // &
            real_str(config%orbits%final_time) // &
            " on " // &
            workers_text(farm, config%orbits%threads)
        call run_ensemble(sys, states, settings, results, status, farm=farm)
        if (.not. collector) then
            exit_code = EXIT_OK
            if (.not. status%ok()) exit_code = EXIT_FAILURE
            return
        end if
        if (.not. status%ok()) then
            write (err_unit, '(a)') "holosym poincare: error: " // &
                status_code_name(status%code) // ": " // status%message
            return
        end if
        call system_clock(clock_end)
        call write_crossings(config, sys%n, results, out, err_unit, &
                             real(clock_end - clock_start, wp) / clock_rate, exit_code)
    end subroutine run_poincare_command

    !> The orbits' initial states: --states, --perturb, or the system's start alone.
    subroutine orbit_states(config, q0, p0, n, states, status)
        type(poincare_config_t), intent(in) :: config
        real(wp), intent(in) :: q0(:), p0(:)
        integer, intent(in) :: n
        type(ensemble_states_t), intent(out) :: states
        type(holosym_status_t), intent(out) :: status
        if (config%orbits%perturb > 0) then
            call perturbed_states(q0, p0, config%orbits%perturb, config%orbits%scale, &
                                  config%orbits%seed, &
                                  states, status)
        else if (len(config%orbits%states) > 0) then
            call read_ensemble_states(config%orbits%states, n, states, status)
        else
            states%id = [1]
            states%q = reshape(q0, [n, 1])
            states%p = reshape(p0, [n, 1])
            status%code = HOLOSYM_SUCCESS
            status%message = ""
        end if
    end subroutine orbit_states

    !> The CSV of the crossings (orbits in the order of their ids) and the summary; an
    !! orbit's failure and an orbit that never crossed on stderr.
    subroutine write_crossings(config, n, results, out, err_unit, seconds, exit_code)
        type(poincare_config_t), intent(in) :: config
        integer, intent(in) :: n
        type(ensemble_result_t), intent(in) :: results(:)
        type(output_t), intent(inout) :: out
        integer, intent(in) :: err_unit
        real(wp), intent(in) :: seconds
        integer, intent(out) :: exit_code
        type(output_t) :: file
        type(holosym_status_t) :: status
        integer, allocatable :: order(:)
        character(len=:), allocatable :: row
        integer :: i, j, k, total, failed, silent
        exit_code = EXIT_FAILURE
        if (len(config%orbits%output) > 0) then
            call open_output(config%orbits%output, file, status)
            if (.not. status%ok()) then
                write (err_unit, '(a)') "holosym poincare: error: " // status%message
                return
            end if
        end if
        row = "orbit,t,"
        call append_numbered(row, "q", n, ",")
        row = row // ","
        call append_numbered(row, "p", n, ",")
        call put_line(row)
        order = sorted_order([(results(k)%id, k = 1, size(results))])
        total = 0
        failed = 0
        silent = 0
        do k = 1, size(order)
            associate (r => results(order(k)))
                do j = 1, size(r%crossings, 2)
                    row = int_str(r%id)
                    do i = 1, 2 * n + 1
                        row = row // "," // csv_real(r%crossings(i, j))
                    end do
                    call put_line(row)
                end do
                total = total + size(r%crossings, 2)
                if (size(r%crossings, 2) == 0) silent = silent + 1
                if (r%code /= HOLOSYM_SUCCESS) then
                    failed = failed + 1
                    write (err_unit, '(a)') "holosym poincare: orbit " // int_str(r%id) // &
                        " failed after " // int_str(r%steps_done) // " steps (" // &
                        int_str(size(r%crossings, 2)) // " crossings kept): " // &
                        status_code_name(r%code) // ": " // r%message
                end if
            end associate
        end do
        if (len(config%orbits%output) > 0) then
            call file%close(status)
            if (.not. status%ok()) then
                write (err_unit, '(a)') "holosym poincare: error: " // status%message
                return
            end if
        end if
        if (total == 0) then
            write (err_unit, '(a)') "holosym poincare: error: the section " // &
                config%section // " = 0 was not crossed " // &
                trim(direction_name(config%direction)) // " by any orbit up to T = " // &
                real_str(config%orbits%final_time) // " (check the expression, the direction " // &
                "and T)"
            return
        end if
        if (.not. config%orbits%quiet) write (err_unit, '(a)') "holosym poincare: " // &
            plural(total, "crossing") // " of " // plural(size(results), "orbit") // " (" // &
            int_str(silent) // " without a crossing, " // int_str(failed) // " failed) in " &
            // seconds_text(seconds, '(f0.2)') // " s"
        if (failed == 0) exit_code = EXIT_OK
    contains
        subroutine put_line(text)
            character(len=*), intent(in) :: text
            if (len(config%orbits%output) > 0) then
                call file%line(text)
            else
                call out%line(text)
            end if
        end subroutine put_line
    end subroutine write_crossings

    !> "1 orbit", "3 orbits".
    function plural(count, noun) result(text)
        integer, intent(in) :: count
        character(len=*), intent(in) :: noun
        character(len=:), allocatable :: text
        text = int_str(count) // " " // noun
        if (count /= 1) text = text // "s"
    end function plural

    !> "rising", "falling" or "either way".
    pure function direction_name(direction) result(name)
        integer, intent(in) :: direction
        character(len=10) :: name
        select case (direction)
        case (EVENT_RISING)
            name = "rising"
        case (EVENT_FALLING)
            name = "falling"
        case default
            name = "either way"
        end select
    end function direction_name

end module holosym_cli_poincare

!> Holds `not_installed`: fpm installs no module of a source with a submodule.
submodule (holosym_cli_poincare) holosym_cli_poincare_app
    implicit none
contains
    module procedure not_installed
    end procedure not_installed
end submodule holosym_cli_poincare_app
