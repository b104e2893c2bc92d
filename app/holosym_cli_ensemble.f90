!> The `ensemble` command of the `holosym` tool: many trajectories of one system, from
!! initial states read from CSV or generated around the system's initial state, in
!! parallel (OpenMP threads; MPI ranks in the holosym-mpi build), one result row per
!! trajectory written the moment it completes, resumable after a kill.
!!
!! The work is the library's (`run_ensemble`, `ensemble_csv_sink`); this module parses the
!! options, builds the states and the settings, and reports. With an MPI farm every rank
!! runs this command with the same arguments: all of them read or generate the same
!! states, only the collector (rank 0) touches the results file and the timing log.
module holosym_cli_ensemble
    use, intrinsic :: iso_fortran_env, only: int64
    use holosym_kinds, only: wp
    use holosym_text_file, only: text_line_t, printable
    use holosym_status_codes, only: holosym_status_t, status_code_name, int_str, real_str, &
        HOLOSYM_SUCCESS
    use holosym_problem, only: constrained_hamiltonian
    use holosym_integrator, only: constrained_integrator
    use holosym_accuracy, only: accuracy_plan_t, init_for_accuracy
    use holosym_task_farm, only: task_farm, openmp_farm
    use holosym_ensemble, only: ensemble_settings_t, ensemble_states_t, ensemble_result_t, &
        run_ensemble, check_ensemble, perturbed_states
    use holosym_ensemble_files, only: read_ensemble_states, ensemble_csv_sink, seconds_text
    use holosym_systems, only: system_source_t, make_source_system, system_choices, &
        default_links, max_links
    use holosym_scheme, only: max_order_m, max_order_n, max_gauss_points
    use holosym_cli_common, only: parsed_command_proceeds, cli_argument_t, split_option, &
        option_value, parse_integer, parse_integer_in, parse_real, fail, csv_real, &
        join_lines, default_orders, EXIT_OK, EXIT_FAILURE
    use holosym_output, only: output_t, make_directories, same_file
    implicit none
    private

    public :: ensemble_config_t, parse_ensemble_options, ensemble_command, ensemble_help
    public :: workers_text, perturb_options_help, system_options_help, take_run_option, &
        steps_fit

    !> Largest --perturb (trajectories generated; each keeps its state and result).
    integer, parameter :: max_perturb = 1000000
    !> Largest --threads.
    integer, parameter :: max_threads = 256
    !> Largest --scale (a perturbation beyond it leaves no trace of the start).
    real(wp), parameter :: max_scale = 1000

    !> Options of `holosym ensemble`.
    type :: ensemble_config_t
        type(system_source_t) :: source          !! built-in system or model file
        integer :: order_m = 2                   !! M
        integer :: order_n = 1                   !! N (default M - 1)
        integer :: gauss_points = 3              !! G (default max(M, N) + 1)
        real(wp) :: step_size = 0.0625_wp        !! default h
        real(wp) :: final_time = 10.0_wp         !! default T
        !> --accuracy: the max |error| wanted at T (0: not given); (M, N, G), h and the
        !! Newton tolerance are then planned from the system's start (`init_for_accuracy`).
        real(wp) :: accuracy = 0
        character(len=:), allocatable :: states  !! states CSV ("" with --perturb)
        integer :: perturb = 0                   !! number of generated states (0: none)
        real(wp) :: scale = 1.0e-3_wp            !! perturbation size
        integer :: seed = 1                      !! generator seed
        character(len=:), allocatable :: output  !! results file
        character(len=:), allocatable :: timing  !! timing log
        character(len=:), allocatable :: samples !! samples directory ("" for none)
        integer :: every = 0                     !! sample stride (0: none)
        logical :: project = .false.             !! project the states first
        logical :: resume = .false.              !! complete an interrupted run
        integer :: threads = 0                   !! OpenMP threads (0: OMP_NUM_THREADS)
        logical :: quiet = .false.               !! no progress lines
        logical :: help = .false.                !! --help given
    end type ensemble_config_t

    interface
        !> Does nothing. Its body, in the submodule at the end of this file, keeps this
        !! application module out of `fpm install` (see fpm.toml).
        module subroutine not_installed()
        end subroutine not_installed
    end interface

contains

    !> The text of `holosym ensemble --help`.
    pure function ensemble_help() result(text)
        character(len=:), allocatable :: text !! the help
        text = join_lines([character(len=96) :: &
            "Usage: holosym ensemble (--states FILE | --perturb K) --output FILE [options]", &
            "", &
            "Integrate many trajectories of one system in parallel and write one result row", &
            "per trajectory, in the order they complete; when all are done the rows are", &
            "sorted by id, so the file is the same whatever the threads or MPI ranks.", &
            "", &
            "Initial states (one of):", &
            "  --states FILE   CSV rows id,q1..qn,p1..pn[,h][,T] (optional header naming", &
            "                  these columns; '#' lines ignored); h and T per trajectory", &
            perturb_options_help(), &
            "", &
            "Options:", &
            system_options_help(), &
            "  --h REAL        step size of rows without their own h        [0.0625]", &
            "  --T REAL        final time of rows without their own T       [10]", &
            "  --accuracy TOL  the max |error| wanted at T, in (0, 1): (M, N, G), h and the", &
            "                  Newton tolerance planned from the system's start (as", &
            "                  simulate --accuracy; not with --M, --N, --G, --h)", &
            "  --output FILE   results CSV (required; an existing file is refused unless", &
            "                  --resume)", &
            "  --timing FILE   CPU and wall seconds per trajectory [OUTPUT without .csv,", &
            "                  + .timing.csv]", &
            "  --samples DIR   the state every K steps into DIR/<id>.csv (one per trajectory)", &
            "  --every K       sample stride for --samples, >= 1            [1]", &
            "  --project       project off-manifold --states rows onto the manifold first", &
            "                  (without it they are an error)", &
            "  --resume        complete an interrupted run: keep the rows of OUTPUT and", &
            "                  compute only the missing ids (same options required)", &
            "  --threads N     OpenMP threads, 1..256                       [OMP_NUM_THREADS]", &
            "  --quiet         no progress lines", &
            "  -h, --help      show this help", &
            "", &
            "Results: a line '# <the run's settings>', the header, then", &
            "id,code,steps,steps_done,q1..qn,p1..pn,max_energy_error,", &
            "max_constraint_residual,max_velocity_residual,newton_iterations,message", &
            "(code 0: success; else the status code, and the message says why).", &
            "Progress (done/total, rate, time left) on stderr. Exit status: 0 every row", &
            "written (failed trajectories included), 1 bad input or I/O failure (a full", &
            "disk too), 2 bad usage.", &
            "", &
            "Example:", &
            "  holosym ensemble --system pendulum --perturb 100 --scale 0.01 --T 10 \", &
            "      --output pendulum.csv"])
    end function ensemble_help

    !> The help lines of --perturb, --scale and --seed (ensemble and poincare).
    pure function perturb_options_help() result(lines)
        character(len=96) :: lines(5) !! the lines
        lines = [character(len=96) :: &
            "  --perturb K     K states around the system's initial state, ids 1..K (K up", &
            "                  to 1000000): each q_i and p_i moved by S u, u uniform in", &
            "                  [-1, 1), then projected", &
            "  --scale S       perturbation size, 0 to 1000                 [1e-3]", &
            "  --seed N        generator seed                               [1]"]
    end function perturb_options_help

    !> The help lines of the system and the scheme: --system, --links, --model, --set,
    !! --M, --N, --G (ensemble and poincare).
    pure function system_options_help() result(lines)
        character(len=96) :: lines(7) !! the lines
        lines = [character(len=96) :: &
            "  --system NAME   built-in system                              [pendulum]", &
            "                  (" // system_choices // ")", &
            "  --links K       links of --system chain, 1 to " // int_str(max_links) // &
            "         [" // int_str(default_links) // "]", &
            "  --model FILE    the system of a model file instead of --system", &
            "                  (docs/models.md)", &
            "  --set NAME=X    set parameter NAME of the model to X (repeatable)", &
            "  --M, --N, --G   the scheme: M 1..30, N 0..30, G N+1..64      [2, M-1, max(M,N)+1]"]
    end function system_options_help

    !> Parse the options of `ensemble`. Failure: HOLOSYM_INVALID_ARGUMENT naming the option.
    subroutine parse_ensemble_options(args, config, status)
        type(cli_argument_t), intent(in) :: args(:)     !! the command's arguments
        type(ensemble_config_t), intent(out) :: config  !! parsed settings
        type(holosym_status_t), intent(out) :: status   !! outcome
        character(len=:), allocatable :: name, inline, value
        logical :: has_inline, n_given, g_given, every_given, timing_given, taken
        character(len=:), allocatable :: chosen
        integer :: i

        chosen = ""
        config%states = ""
        config%output = ""
        config%timing = ""
        config%samples = ""
        status%code = HOLOSYM_SUCCESS
        status%message = ""
        n_given = .false.
        g_given = .false.
        every_given = .false.
        timing_given = .false.
        i = 1
        do while (i <= size(args))
            call split_option(args(i)%text, name, inline, has_inline)
            select case (name)
            case ("-h", "--help")
                config%help = .true.
                return
            case ("--project", "--resume", "--quiet")
                if (has_inline) then
                    call fail(status, "option " // name // " takes no value")
                    return
                end if
                if (name == "--project") config%project = .true.
                if (name == "--resume") config%resume = .true.
                if (name == "--quiet") config%quiet = .true.
            case ("--system", "--model", "--set", "--M", "--N", "--G", "--h", "--T", &
                  "--states", "--perturb", "--scale", "--seed", "--output", "--timing", &
                  "--samples", "--every", "--threads", "--accuracy")
                call option_value(args, i, name, inline, has_inline, value, status)
                if (.not. status%ok()) return
                call config%source%take(name, value, taken, status)
                if (.not. status%ok()) return
                select case (name)
                case ("--M", "--N", "--G", "--h")
                    chosen = name
                end select
                select case (name)
                case ("--accuracy")
                    call parse_real(name, value, config%accuracy, status)
                    call require(config%accuracy > 0 .and. config%accuracy < 1, "in (0, 1)")
                case ("--timing")
                    config%timing = value
                    timing_given = .true.
                case ("--samples")
                    config%samples = value
                case ("--every")
                    call parse_integer_in(name, value, 1, huge(1), config%every, status)
                    every_given = .true.
                case default
                    if (.not. taken) call take_run_option(name, value, config, taken, &
                                                          n_given, g_given, status)
                end select
                if (.not. status%ok()) return
            case default
                call fail(status, "unknown option '" // args(i)%text // "'")
                return
            end select
            i = i + 1
        end do
        call config%source%check(status)
        if (.not. status%ok()) return
        call default_orders(config%order_m, config%order_n, config%gauss_points, n_given, &
                            g_given, status)
        if (.not. status%ok()) return
        if (config%accuracy > 0 .and. len(chosen) > 0) then
            call fail(status, "option --accuracy chooses (M, N, G) and h; it cannot be " // &
                "combined with " // chosen)
        else if (config%accuracy > 0 .and. .not. config%final_time > 0) then
            call fail(status, "option --accuracy needs --T > 0")
        else if (.not. steps_fit(config%final_time, config%step_size)) then
            call fail(status, "options --T and --h: T/h must give 1 to " // &
                int_str(huge(1)) // " steps (or T = 0)")
        else if (len(config%states) > 0 .eqv. config%perturb > 0) then
            call fail(status, "give exactly one of --states FILE and --perturb K")
        else if (len(config%output) == 0) then
            call fail(status, "option --output FILE is required")
        else if (every_given .and. len(config%samples) == 0) then
            call fail(status, "option --every needs --samples DIR")
        end if
        if (len(config%samples) > 0 .and. .not. every_given) config%every = 1
        if (.not. timing_given) config%timing = timing_name(config%output)
        if (status%ok()) call check_distinct_files(config, status)
    contains
        subroutine require(condition, bound)
            logical, intent(in) :: condition
            character(len=*), intent(in) :: bound
            if (status%ok() .and. .not. condition) call fail(status, "option " // name // &
                " must be " // bound // "; got '" // value // "'")
        end subroutine require
    end subroutine parse_ensemble_options

    !> Take an option that `ensemble` and `poincare` share into `config` (`taken`; false
    !! for any other): the scheme (--M, --N, --G; `n_given`, `g_given` set), --h, --T, the
    !! states (--states, --perturb, --scale, --seed), --output and --threads. Failure:
    !! HOLOSYM_INVALID_ARGUMENT naming the option and its bound.
    subroutine take_run_option(name, value, config, taken, n_given, g_given, status)
        character(len=*), intent(in) :: name, value   !! the option and its value
        type(ensemble_config_t), intent(inout) :: config !! the settings so far
        logical, intent(out) :: taken                 !! it was one of these
        logical, intent(inout) :: n_given, g_given    !! --N, --G seen
        type(holosym_status_t), intent(inout) :: status !! outcome
        taken = .true.
        select case (name)
        case ("--M")
            call parse_integer_in(name, value, 1, max_order_m, config%order_m, status)
        case ("--N")
            call parse_integer_in(name, value, 0, max_order_n, config%order_n, status)
            n_given = .true.
        case ("--G")
            call parse_integer_in(name, value, 1, max_gauss_points, config%gauss_points, &
                                  status)
            g_given = .true.
        case ("--h")
            call parse_real(name, value, config%step_size, status)
            call require(config%step_size > 0, "> 0")
        case ("--T")
            call parse_real(name, value, config%final_time, status)
            call require(config%final_time >= 0, ">= 0")
        case ("--states")
            config%states = value
        case ("--perturb")
            call parse_integer_in(name, value, 1, max_perturb, config%perturb, status)
        case ("--scale")
            call parse_real(name, value, config%scale, status)
            call require(config%scale >= 0 .and. config%scale <= max_scale, "in [0, 1000]")
        case ("--seed")
            call parse_integer(name, value, config%seed, status)
        case ("--output")
            config%output = value
        case ("--threads")
            call parse_integer_in(name, value, 1, max_threads, config%threads, status)
        case default
            taken = .false.
        end select
    contains
        subroutine require(condition, bound)
            logical, intent(in) :: condition
            character(len=*), intent(in) :: bound
            if (status%ok() .and. .not. condition) call fail(status, "option " // name // &
                " must be " // bound // "; got '" // value // "'")
        end subroutine require
    end subroutine take_run_option

    !> No two of --output, --timing, --samples and --states may name the same file (the
    !! same path, or the same file under two names: `same_file`). Failure:
    !! HOLOSYM_INVALID_ARGUMENT naming both options.
    subroutine check_distinct_files(config, status)
        type(ensemble_config_t), intent(in) :: config !! the parsed options
        type(holosym_status_t), intent(inout) :: status !! outcome
        character(len=*), parameter :: options(4) = [character(len=9) :: "--output", &
            "--timing", "--samples", "--states"]
        type(text_line_t) :: paths(4)
        integer :: i, j
        paths(1)%text = config%output
        paths(2)%text = config%timing
        paths(3)%text = config%samples
        paths(4)%text = config%states
        do i = 1, size(paths)
            do j = i + 1, size(paths)
                if (len(paths(i)%text) == 0 .or. len(paths(j)%text) == 0) cycle
                if (.not. same_file(paths(i)%text, paths(j)%text)) cycle
                call fail(status, "options " // trim(options(i)) // " '" // &
                    printable(paths(i)%text) // "' and " // trim(options(j)) // " '" // &
                    printable(paths(j)%text) // "' name the same file; give each its own")
                return
            end do
        end do
    end subroutine check_distinct_files

    !> Whether T/h (T >= 0, h > 0, both finite) rounds to 1 .. huge(1) steps, or T = 0;
    !! decided on the exponents before dividing, so nothing overflows.
    pure logical function steps_fit(span, h) result(fits)
        real(wp), intent(in) :: span, h
        real(wp) :: ratio
        fits = span == 0
        if (fits .or. .not. span > 0) return
        if (exponent(span) - exponent(h) > bit_size(1)) return
        ratio = span / h
        fits = ratio < real(huge(1), wp) .and. nint(ratio) >= 1
    end function steps_fit

    !> The default timing log of a results file: "out.csv" gives "out.timing.csv".
    pure function timing_name(output) result(name)
        character(len=*), intent(in) :: output
        character(len=:), allocatable :: name
        integer :: stem
        stem = len(output)
        if (len(output) > 4) then
            if (output(len(output) - 3:) == ".csv") stem = len(output) - 4
        end if
        name = output(:stem) // ".timing.csv"
    end function timing_name

    !> A digest of the states (31-bit, of their bytes): a resumed run must have the same.
    function states_digest(states) result(text)
        type(ensemble_states_t), intent(in) :: states
        character(len=:), allocatable :: text
        integer(int64), parameter :: modulus = 2147483647_int64
        integer(int64) :: digest
        character(len=16) :: buffer
        digest = 0
        call add(transfer(states%id, [character(len=1) ::]))
        call add(transfer(states%q, [character(len=1) ::]))
        call add(transfer(states%p, [character(len=1) ::]))
        if (allocated(states%step_size)) call add(transfer(states%step_size, &
            [character(len=1) ::]))
        if (allocated(states%final_time)) call add(transfer(states%final_time, &
            [character(len=1) ::]))
        write (buffer, '(z8.8)') digest
        text = trim(buffer)
    contains
        subroutine add(bytes)
            character(len=1), intent(in) :: bytes(:)
            integer :: i
            do i = 1, size(bytes)
                digest = modulo(digest * 257 + ichar(bytes(i)), modulus)
            end do
        end subroutine add
    end function states_digest

    !> `holosym ensemble ARGS`: parse, build the states, run, report. `farm` (default: the
    !! OpenMP threads of --threads) computes the trajectories.
    subroutine ensemble_command(args, out, err_unit, exit_code, farm)
        type(cli_argument_t), intent(in) :: args(:) !! arguments after "ensemble"
        type(output_t), intent(inout) :: out !! the help
        integer, intent(in) :: err_unit   !! unit for progress and errors
        integer, intent(out) :: exit_code !! process exit code
        class(task_farm), intent(inout), optional :: farm !! who computes (MPI: every rank)
        type(ensemble_config_t) :: config
        type(holosym_status_t) :: status
        type(openmp_farm) :: threads

        call parse_ensemble_options(args, config, status)
        if (.not. parsed_command_proceeds("ensemble", status, config%help, ensemble_help(), &
                                          out, err_unit, exit_code)) return
        threads%threads = config%threads
        if (present(farm)) then
            call run_ensemble_command(config, farm, err_unit, exit_code)
        else
            call run_ensemble_command(config, threads, err_unit, exit_code)
        end if
    end subroutine ensemble_command

    !> --accuracy: the plan of `init_for_accuracy` from the system's start (q0, p0) to
    !! --T, into the ensemble's settings (the scheme, h, the Newton tolerance); its line on
    !! `err_unit` when `tell`.
    subroutine plan_ensemble(config, sys, q0, p0, settings, tell, err_unit, status)
        type(ensemble_config_t), intent(in) :: config
        class(constrained_hamiltonian), intent(in), target :: sys
        real(wp), intent(in) :: q0(:), p0(:)
        type(ensemble_settings_t), intent(inout) :: settings
        logical, intent(in) :: tell
        integer, intent(in) :: err_unit
        type(holosym_status_t), intent(out) :: status
        type(constrained_integrator) :: planner
        type(accuracy_plan_t) :: plan
        call init_for_accuracy(planner, sys, q0, p0, config%accuracy, config%final_time, &
                               plan, status)
        if (.not. status%ok()) then
            status%message = "--accuracy: " // status%message
            return
        end if
        settings%order_m = plan%order_m
        settings%order_n = plan%order_n
        settings%gauss_points = plan%gauss_points
        settings%step_size = plan%h
        settings%integrator%newton%tolerance = plan%newton_tolerance
        if (tell) write (err_unit, '(a)') "holosym ensemble: --accuracy " // &
            real_str(config%accuracy) // " at T = " // real_str(config%final_time) // &
            " from the system's start: h = " // real_str(plan%h) // ", estimated error " // &
            real_str(plan%estimate) // ", Newton tolerance " // &
            real_str(plan%newton_tolerance) // " (pilot: " // int_str(plan%pilot_steps) // &
            " steps)"
    end subroutine plan_ensemble

    !> Run a parsed `ensemble` command on a farm.
    subroutine run_ensemble_command(config, farm, err_unit, exit_code)
        type(ensemble_config_t), intent(in) :: config !! the options
        class(task_farm), intent(inout) :: farm       !! who computes
        integer, intent(in) :: err_unit               !! progress and errors
        integer, intent(out) :: exit_code             !! process exit code
        class(constrained_hamiltonian), allocatable :: sys
        type(ensemble_states_t) :: states
        type(ensemble_settings_t) :: settings
        type(ensemble_result_t), allocatable :: results(:)
        type(ensemble_csv_sink) :: sink
        type(holosym_status_t) :: status, finished
        real(wp), allocatable :: q0(:), p0(:)
        logical, allocatable :: skip(:)
        character(len=:), allocatable :: description, note, identity
        integer(int64) :: clock_start, clock_end, clock_rate
        logical :: collector

        exit_code = EXIT_FAILURE
        collector = farm%is_collector()
        call system_clock(clock_start, clock_rate)
        call make_source_system(config%source, sys, q0, p0, status, note, identity)
        if (status%ok() .and. len(note) > 0 .and. collector .and. .not. config%quiet) &
            write (err_unit, '(a)') "holosym ensemble: note: " // note
        if (status%ok()) then
            if (config%perturb > 0) then
                call perturbed_states(q0, p0, config%perturb, config%scale, config%seed, &
                                      states, status)
            else
                call read_ensemble_states(config%states, sys%n, states, status)
            end if
        end if
        settings%order_m = config%order_m
        settings%order_n = config%order_n
        settings%gauss_points = config%gauss_points
        settings%step_size = config%step_size
        settings%final_time = config%final_time
        if (status%ok() .and. config%accuracy > 0) call plan_ensemble(config, sys, q0, p0, &
            settings, collector .and. .not. config%quiet, err_unit, status)
        settings%every = config%every
        settings%project = config%project .or. config%perturb > 0
        if (status%ok()) call check_ensemble(sys, states, settings, status)
        if (status%ok() .and. len(config%samples) > 0) call make_directories(config%samples, &
                                                                            status)
        sink%label = "holosym ensemble: "
        sink%samples_dir = config%samples
        if (.not. config%quiet) sink%progress_unit = err_unit
        if (.not. allocated(identity)) identity = config%source%label()
        description = "holosym ensemble system=" // identity // " M=" // &
            int_str(settings%order_m) // " N=" // int_str(settings%order_n) // " G=" // &
            int_str(settings%gauss_points) // " h=" // csv_real(settings%step_size) // " T=" // &
            csv_real(config%final_time) // " project=" // &
            trim(merge("yes", "no ", settings%project)) // " every=" // int_str(config%every)
        if (config%accuracy > 0) description = description // " accuracy=" // &
            csv_real(config%accuracy) // " newton_tolerance=" // &
            csv_real(settings%integrator%newton%tolerance)
        if (status%ok()) description = description // " states=" // states_digest(states)
        ! Only the collector owns the results file; every process learns whether it opened.
        if (status%ok() .and. collector) call sink%open(config%output, config%timing, &
            description, sys%n, states%id, config%resume, skip, status)
        if (.not. farm%agree(status%ok())) then
            if (.not. status%ok()) write (err_unit, '(a)') "holosym ensemble: error: " // &
                status%message
            return
        end if
        if (.not. allocated(skip)) allocate (skip(size(states%id)), source=.false.)
        if (collector .and. .not. config%quiet) write (err_unit, '(a)') &
            "holosym ensemble: " // config%source%label() // " (n = " // int_str(sys%n) // &
            ", m = " // int_str(sys%m) // "), (M, N, G) = (" // int_str(settings%order_m) // &
            ", " // int_str(settings%order_n) // ", " // int_str(settings%gauss_points) // "), " &
            // int_str(size(states%id)) // " trajectories, " // int_str(count(skip)) // &
            " already done, " // int_str(count(.not. skip)) // " to run on " // &
            workers_text(farm, config%threads)
        call run_ensemble(sys, states, settings, results, status, sink, farm, skip)
        if (.not. collector) then
            exit_code = EXIT_OK
            if (.not. status%ok()) exit_code = EXIT_FAILURE
            return
        end if
        ! A run the sink halted (a write failed) reports the sink's failure alone.
        call sink%finish(finished)
        if (.not. finished%ok()) then
            write (err_unit, '(a)') "holosym ensemble: error: " // finished%message
            return
        else if (.not. status%ok()) then
            write (err_unit, '(a)') "holosym ensemble: error: " // &
                status_code_name(status%code) // ": " // status%message
            return
        end if
        call system_clock(clock_end)
        if (.not. config%quiet) write (err_unit, '(a)') "holosym ensemble: " // &
            int_str(count(.not. skip)) // " trajectories in " // &
            seconds_text(real(clock_end - clock_start, wp) / clock_rate, '(f0.2)') // " s (" // &
            int_str(sink%failures()) // " failed); results in " // config%output
        exit_code = EXIT_OK
    end subroutine run_ensemble_command

    !> "2 threads" or "3 MPI ranks", for the start line.
    function workers_text(farm, threads) result(text)
        !$ use omp_lib, only: omp_get_max_threads
        class(task_farm), intent(inout) :: farm
        integer, intent(in) :: threads
        character(len=:), allocatable :: text
        integer :: count
        if (farm%processes() > 1) then
            text = int_str(farm%processes()) // " MPI ranks"
            return
        end if
        count = max(threads, 1)
        !$ if (threads == 0) count = omp_get_max_threads()
        text = int_str(count) // " thread" // trim(merge("s", " ", count > 1))
    end function workers_text

end module holosym_cli_ensemble

!> Holds `not_installed`: fpm installs no module of a source with a submodule.
submodule (holosym_cli_ensemble) holosym_cli_ensemble_app
    implicit none
contains
    module procedure not_installed
    end procedure not_installed
end submodule holosym_cli_ensemble_app
