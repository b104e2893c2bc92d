!> The `simulate` command of the `holosym` tool: integrate one of the paper's systems from
!! its initial state and write the trajectory as CSV.
!!
!! Parsing (`parse_simulate_options`) and running (`run_simulate`) are separate procedures
!! that return a status instead of stopping; `simulate_command` combines them and turns the
!! outcome into an exit code.
module holosym_cli_simulate
    use, intrinsic :: iso_fortran_env, only: int64
    use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan
    use holosym_kinds, only: wp
    use holosym_status_codes, only: holosym_status_t, status_code_name, int_str, real_str, &
        append_numbered, HOLOSYM_SUCCESS, HOLOSYM_INVALID_ARGUMENT
    use holosym_problem, only: constrained_hamiltonian
    use holosym_integrator, only: constrained_integrator, step_info_t, step_observer
    use holosym_accuracy, only: accuracy_plan_t, init_for_accuracy
    use holosym_events, only: event_t, integrate_events, model_events
    use holosym_formula_model, only: formula_model
    use holosym_manifold, only: manifold_residuals
    use holosym_observers, only: trajectory_header
    use holosym_systems, only: system_source_t, make_source_system
    use holosym_scheme, only: max_order_m, max_order_n, max_gauss_points
    use holosym_output, only: output_t, open_output
    use holosym_cli_common, only: parsed_command_proceeds, &
        cli_argument_t, split_option, option_value, parse_integer, parse_integer_in, &
        parse_real, fail, csv_real, csv_integer, join_lines, default_orders, EXIT_OK, &
        EXIT_FAILURE, EXIT_USAGE
    implicit none
    private

    public :: simulate_config_t, simulate_summary_t
    public :: parse_simulate_options, run_simulate, simulate_command, simulate_help
    public :: csv_header

    !> Default degree M of the displacement polynomial.
    integer, parameter :: default_order_m = 2
    !> Default step size h = 1/16.
    real(wp), parameter :: default_step_size = 0.0625_wp
    !> Default final time T.
    real(wp), parameter :: default_final_time = 10.0_wp
    !> Default row stride.
    integer, parameter :: default_every = 1
    !> Relative tolerance for "T is a multiple of h": decimal input such as 0.1 is not exact
    !! in binary, so T/h may miss an integer by a few units of round-off.
    real(wp), parameter :: multiple_tolerance = 64 * epsilon(1.0_wp)
    !> Seconds of wall time between progress lines on standard error.
    real(wp), parameter :: progress_interval = 10.0_wp

    !> Options of `holosym simulate`, after parsing and defaulting.
    type :: simulate_config_t
        !> The system: built-in (--system, --links) or a model file (--model, --set).
        type(system_source_t) :: source
        !> M >= 1: degree of the displacement polynomial.
        integer :: order_m = default_order_m
        !> N >= 0: degree of the momentum polynomial (default M - 1).
        integer :: order_n = default_order_m - 1
        !> G >= 1: Gauss-Legendre points (default max(M, N) + 1).
        integer :: gauss_points = default_order_m + 1
        !> Step size h > 0.
        real(wp) :: step_size = default_step_size
        !> Final time T >= 0 (used when --steps is absent).
        real(wp) :: final_time = default_final_time
        !> Number of steps: --steps, or nint(T/h).
        integer :: steps = 0
        !> Write a row every `every` steps (t = 0 and the last step always).
        integer :: every = default_every
        !> The plain path (--plain): the general scheme by full Newton with the
        !! working-precision LU and no speed options; the same results to round-off, many
        !! times slower.
        logical :: plain = .false.
        !> --iteration: the iteration of the step's equations ('automatic' or 'newton',
        !! `constrained_integrator%iteration`).
        character(len=:), allocatable :: iteration
        !> --sums: the inner sums of the residual ('working' or 'double-double',
        !! `constrained_integrator%residual_sums`).
        character(len=:), allocatable :: sums
        !> --accuracy: the requested max |error| of q and p at T (0: not given); holosym
        !! then chooses (M, N, G), h and the Newton tolerance (`init_for_accuracy`).
        real(wp) :: accuracy = 0
        !> Output file; empty for the output unit given to `run_simulate`.
        character(len=:), allocatable :: output
        !> --events: the file of the model's events (its `event` statements); empty: none.
        character(len=:), allocatable :: events
        !> True when --help was given (nothing else is then checked).
        logical :: help = .false.
        !> A remark for standard error (e.g. T not a multiple of h); empty if none.
        character(len=:), allocatable :: note
    end type simulate_config_t

    !> What a run did: counts and the largest errors over all steps (not only written rows).
    type :: simulate_summary_t
        !> Steps completed.
        integer :: steps_done = 0
        !> CSV data rows written (the header not counted).
        integer :: rows = 0
        !> Energy H0 of the initial state.
        real(wp) :: initial_energy = 0
        !> max |(H - H0)/H0| (max |H - H0| when H0 = 0).
        real(wp) :: max_energy_error = 0
        !> Largest constraint residual max|phi| seen over the steps' displacement nodes.
        real(wp) :: max_constraint_residual = 0
        !> Largest max|phi| at the start and the steps' end states.
        real(wp) :: max_end_constraint_residual = 0
        !> Largest hidden-constraint residual max|Phi H_p| seen.
        real(wp) :: max_velocity_residual = 0
        !> Newton iterations over all steps.
        integer :: newton_iterations = 0
        !> Most Newton iterations in one step.
        integer :: max_newton_iterations = 0
        !> Newton matrices formed and factored, and iterations without one, over all steps
        !! (the integrator's `stats`).
        integer(int64) :: factorizations = 0, approximate_iterations = 0
        !> Working-precision residuals summed in double-double arithmetic.
        integer(int64) :: paired_residuals = 0
        !> Wall-clock seconds of the integration.
        real(wp) :: wall_time = 0
    end type simulate_summary_t

    !> Observer writing CSV rows and collecting the summary.
    type, extends(step_observer) :: csv_writer
        class(constrained_hamiltonian), allocatable :: sys !! the system, for H and residuals
        type(output_t), pointer :: sink => null() !! where the CSV rows go
        integer :: err_unit = 0        !! unit of the progress lines
        integer :: every = default_every !! row stride
        integer :: total_steps = 0     !! steps of the run (the last one is always written)
        real(wp) :: energy_scale = 1   !! H0, or 1 when H0 = 0
        real(wp), allocatable :: q0(:) !! initial coordinates
        real(wp), allocatable :: p0(:) !! initial momenta
        real(wp) :: position0 = 0      !! max|phi| of the initial state
        real(wp) :: velocity0 = 0      !! max|Phi H_p| of the initial state
        integer(int64) :: clock_start = 0 !! system_clock at the start
        integer(int64) :: clock_rate = 1  !! system_clock ticks per second
        integer(int64) :: clock_last = 0  !! system_clock at the last progress line
        type(simulate_summary_t) :: summary !! counts and maxima so far
    contains
        !> Write rows and update the summary after each step.
        procedure :: observe => csv_writer_observe
    end type csv_writer

    interface
        !> Does nothing. Its body, in the submodule at the end of this file, keeps this
        !! application module out of `fpm install` (see fpm.toml).
        module subroutine not_installed()
        end subroutine not_installed
    end interface

contains

    !> The text of `holosym simulate --help`.
    pure function simulate_help() result(text)
        character(len=:), allocatable :: text !! the help, lines joined by newlines
        text = join_lines([character(len=96) :: &
            "Usage: holosym simulate [options]", &
            "", &
            "Integrate a constrained Hamiltonian system (built in, or from a model file) from", &
            "its initial state with the symplectic scheme (M, N, G) and write the trajectory", &
            "as CSV to standard output.", &
            "", &
            "Options (also accepted as --name=value):", &
            "  --system NAME  pendulum: spherical pendulum, paper Example 1 (n = 3, m = 1)", &
            "                 linkage:  spring-linkage mechanism, Example 2 (n = 6, m = 3)", &
            "                 planar:   planar pendulum (n = 2, m = 1)", &
            "                 chain:    K planar pendula in a chain (n = 2K, m = K), links", &
            "                           at 0.5 rad from the vertical, at rest", &
            "                 double:   double pendulum, masses 1, 2, rods 1, 0.7 (n = 4, m = 2)", &
            "                 dumbbell: two bodies on a sphere joined by a rod (n = 6, m = 3)", &
            "                 magnetic: charged particle on a sphere in a magnetic field,", &
            "                           H not separable (n = 3, m = 1)", &
            "                 generic:  spherical pendulum in a potential without rotational", &
            "                           symmetry (n = 3, m = 1)              [pendulum]", &
            "  --links K      links of the chain, 1 to 100000; cost and memory per step", &
            "                 grow linearly with K                           [8]", &
            "  --model FILE   the system of a model file instead of --system (docs/models.md);", &
            "                 its initial state, projected onto the constraints if off them", &
            "  --set NAME=X   set parameter NAME of the model to the number X (repeatable)", &
            "  --M INT        degree of the displacement polynomial, 1..30   [2]", &
            "  --N INT        degree of the momentum polynomial, 0..30       [M - 1]", &
            "  --G INT        Gauss-Legendre points, N+1..64                 [max(M, N) + 1]", &
            "  --h REAL       step size, > 0; e.g. 0.0625, 6.25e-2 or 1/16   [0.0625]", &
            "  --T REAL       final time, >= 0; nint(T/h) steps are taken    [10]", &
            "                 (a note goes to standard error if T is not a multiple of h;", &
            "                 T/h must give 1..2147483647 steps when T > 0)", &
            "  --steps INT    number of steps, 0..2147483647; overrides --T", &
            "  --accuracy TOL the max |error| of q and p wanted at T, in (0, 1):", &
            "                 holosym chooses (M, N, G), h and the Newton tolerance", &
            "                 from a pilot on the first tenth of the span and", &
            "                 prints its choice and estimate (not with --M, --N,", &
            "                 --G, --h, --steps, --plain)", &
            "  --every INT    write a row every INT steps, 1..2147483647; the rows at", &
            "                 t = 0 and after the last step are always written [1]", &
            "  --output FILE  write the CSV to FILE instead of standard output", &
            "  --events FILE  with --model: locate the events of the model's event", &
            "                 statements and write them to FILE as CSV (event,", &
            "                 name, direction, t, q, p, lambda); a `stop` event", &
            "                 ends the run at the event", &
            "  Numbers: magnitudes from 1e-4931 to 1e+4931 (real64 build: 1e-307 to", &
            "  1e+307), or 0; a quotient a/b is checked the same way.", &
            "  --plain        the general scheme (momenta as unknowns) by full Newton with", &
            "                 the real128 LU, none of the speed options", &
            "                 (simplified Newton, real64 LU and pre-solve, first-order", &
            "                 increments): the same states to round-off, many times slower", &
            "  --iteration NAME  automatic: iterate the step without the Newton matrix", &
            "                 where that contracts (the reduced step); newton: with the", &
            "                 Newton matrix throughout; the same states to the Newton", &
            "                 tolerance                                      [automatic]", &
            "  --sums NAME    the residual's inner sums: working (working precision),", &
            "                 double-double (pairs of real64, 106 bits; real128 build,", &
            "                 Newton tolerance at least 2^-100, as --accuracy derives", &
            "                 it for loose requests) or automatic (double-double where", &
            "                 allowed)                                       [automatic]", &
            "  -h, --help     show this help", &
            "", &
            "Columns: t,q1..qn,p1..pn,lambda1..lambdam,H,energy_error,constraint_residual,", &
            "velocity_residual,newton_iterations, with 36 significant digits (exact in real128).", &
            "  lambda               multipliers at the end of the step (t = 0: at the start", &
            "                       of the first step; NaN when no step is taken)", &
            "  energy_error         (H - H0)/H0", &
            "  constraint_residual  max|phi| over the step's displacement nodes (t = 0: at q0)", &
            "  velocity_residual    max|Phi(q) dH/dp(q, p)| at the row's state", &
            "  newton_iterations    Newton iterations of the step (0 at t = 0)", &
            "", &
            "Progress and a summary go to standard error. Exit status: 0 success, 1 failure", &
            "of the integrator or of the output (rows already written are kept; a full disk,", &
            "a full device or a closed standard output is a failure), 2 bad usage.", &
            "", &
            "Examples:", &
            "  holosym simulate --system linkage --M 3 --N 2 --G 4 --h 0.0625 --T 1", &
            "  holosym simulate --model example/models/fourbar.hsm --set omega=3 --M 4 --T 5"])
    end function simulate_help

    !> Parse the options of `simulate` (the arguments after the command name). On success
    !! `config` holds every setting with defaults filled in and `config%steps` resolved.
    !! On failure `status` has code HOLOSYM_INVALID_ARGUMENT and a message naming the option
    !! and the value. With --help, parsing stops there and `config%help` is true.
    subroutine parse_simulate_options(args, config, status)
        type(cli_argument_t), intent(in) :: args(:)       !! the command's arguments
        type(simulate_config_t), intent(out) :: config    !! parsed settings
        type(holosym_status_t), intent(out) :: status     !! outcome
        character(len=:), allocatable :: name, inline, value
        logical :: has_inline, n_given, g_given, t_given, steps_given, taken
        character(len=:), allocatable :: chosen
        integer :: i

        config%output = ""
        config%events = ""
        config%note = ""
        status%code = HOLOSYM_SUCCESS
        status%message = ""
        n_given = .false.
        g_given = .false.
        t_given = .false.
        steps_given = .false.
        chosen = ""
        i = 1
        do while (i <= size(args))
            call split_option(args(i)%text, name, inline, has_inline)
            select case (name)
            case ("-h", "--help")
                if (has_inline) then
                    call fail(status, "option " // name // " takes no value; got '" // &
                        args(i)%text // "'")
                else
                    config%help = .true.
                end if
                return
            case ("--plain")
                if (has_inline) then
                    call fail(status, "option --plain takes no value; got '" // &
                        args(i)%text // "'")
                    return
                end if
                config%plain = .true.
            case ("--system", "--M", "--m", "--N", "--n", "--G", "--g", "--h", "--T", "--t", &
                  "--steps", "--every", "--output", "--links", "--model", "--set", "--accuracy", &
                  "--events", "--iteration", "--sums")
                call option_value(args, i, name, inline, has_inline, value, status)
                if (.not. status%ok()) return
                call config%source%take(name, value, taken, status)
                if (.not. taken) call set_option(config, name, value, status)
                if (.not. status%ok()) return
                select case (name)
                case ("--M", "--m", "--h", "--N", "--n", "--G", "--g")
                    chosen = name
                end select
                select case (name)
                case ("--N", "--n")
                    n_given = .true.
                case ("--G", "--g")
                    g_given = .true.
                case ("--T", "--t")
                    t_given = .true.
                case ("--steps")
                    steps_given = .true.
                end select
            case default
                if (name(1:min(1, len(name))) == "-") then
                    call fail(status, "unknown option '" // name // "'")
                else
                    call fail(status, "unexpected argument '" // args(i)%text // "'")
                end if
                return
            end select
            i = i + 1
        end do
        call config%source%check(status)
        if (.not. status%ok()) return
        if (len(config%events) > 0 .and. len(config%source%model) == 0) then
            call fail(status, "option --events writes the events of a model file's " // &
                "event statements: give --model")
            return
        end if
        if (config%accuracy > 0) then
            ! --accuracy chooses the scheme and the step; T is the span it plans for.
            if (len(chosen) > 0 .or. steps_given .or. config%plain) then
                if (steps_given) chosen = "--steps"
                if (config%plain) chosen = "--plain"
                call fail(status, "option --accuracy chooses (M, N, G), h and the steps " // &
                    "to T; it cannot be combined with " // chosen)
            else if (.not. config%final_time > 0) then
                call fail(status, "option --accuracy needs --T > 0")
            end if
            return
        end if
        call default_orders(config%order_m, config%order_n, config%gauss_points, n_given, &
                            g_given, status)
        if (.not. status%ok()) return
        if (.not. steps_given) then
            call resolve_steps(config, status)
            if (.not. status%ok()) return
        else if (t_given) then
            config%note = "--steps " // int_str(config%steps) // " overrides --T"
        end if
        ! The times k h of the rows must be representable.
        if (config%steps > 0) then
            if (exponent(config%step_size) + bit_size(config%steps) >= &
                maxexponent(config%step_size)) then
                call fail(status, "options --h and --steps: the final time steps * h " // &
                    "exceeds the largest number")
            end if
        end if
    end subroutine parse_simulate_options

    !> Store one option's value in `config`, checking its syntax and range.
    subroutine set_option(config, name, value, status)
        type(simulate_config_t), intent(inout) :: config !! settings so far
        character(len=*), intent(in) :: name             !! the option as written
        character(len=*), intent(in) :: value            !! its value text
        type(holosym_status_t), intent(out) :: status    !! outcome
        status%code = HOLOSYM_SUCCESS
        status%message = ""
        select case (name)
        case ("--M", "--m")
            call parse_integer_in(name, value, 1, max_order_m, config%order_m, status)
        case ("--N", "--n")
            call parse_integer_in(name, value, 0, max_order_n, config%order_n, status)
        case ("--G", "--g")
            call parse_integer_in(name, value, 1, max_gauss_points, config%gauss_points, status)
        case ("--h")
            call parse_real(name, value, config%step_size, status)
            if (status%ok()) call require(config%step_size > 0, "> 0")
        case ("--T", "--t")
            call parse_real(name, value, config%final_time, status)
            if (status%ok()) call require(config%final_time >= 0, ">= 0")
        case ("--steps")
            call parse_integer_in(name, value, 0, huge(1), config%steps, status)
        case ("--accuracy")
            call parse_real(name, value, config%accuracy, status)
            if (status%ok()) call require(config%accuracy > 0 .and. config%accuracy < 1, &
                "in (0, 1)")
        case ("--every")
            call parse_integer_in(name, value, 1, huge(1), config%every, status)
        case ("--output")
            config%output = value
        case ("--events")
            config%events = value
        case ("--iteration")
            config%iteration = value
            call require(value == "automatic" .or. value == "newton", &
                         "'automatic' or 'newton'")
        case ("--sums")
            config%sums = value
            call require(value == "automatic" .or. value == "working" .or. &
                         value == "double-double", "'automatic', 'working' or 'double-double'")
        end select
    contains
        !> Fail with "option NAME must be BOUND; got VALUE" unless `condition` holds.
        subroutine require(condition, bound)
            logical, intent(in) :: condition      !! the range check
            character(len=*), intent(in) :: bound !! the bound, e.g. ">= 1"
            if (.not. condition) call fail(status, "option " // name // " must be " // bound &
                // "; got '" // value // "'")
        end subroutine require
    end subroutine set_option

    !> Number of steps from T and h: nint(T/h), with a note when T/h is not an integer
    !! within round-off, and a failure when it does not fit an integer or rounds to 0 for
    !! T > 0.
    subroutine resolve_steps(config, status)
        type(simulate_config_t), intent(inout) :: config !! settings; `steps` is set
        type(holosym_status_t), intent(inout) :: status  !! failure when T/h is too large
        real(wp) :: ratio
        ! Decided on the exponents first: T/h must not overflow.
        if (config%final_time > 0) then
            if (exponent(config%final_time) - exponent(config%step_size) > &
                bit_size(config%steps)) then
                call fail(status, "options --T and --h: T/h is more than " // &
                    int_str(huge(config%steps)) // " steps")
                return
            end if
        end if
        ratio = config%final_time / config%step_size
        if (ratio > real(huge(config%steps), wp)) then
            call fail(status, "options --T and --h: T/h is more than " // &
                int_str(huge(config%steps)) // " steps")
            return
        end if
        config%steps = nint(ratio)
        if (config%steps == 0 .and. config%final_time > 0) then
            call fail(status, "options --T and --h: T/h rounds to 0 steps (T is less than " &
                // "h/2); give a larger T, a smaller h or --steps")
            return
        end if
        if (abs(ratio - config%steps) > multiple_tolerance * max(1.0_wp, ratio)) then
            config%note = "T = " // real_str(config%final_time) // " is not a multiple of h = " &
                // real_str(config%step_size) // "; taking nint(T/h) = " // &
                int_str(config%steps) // " steps, to t = " // &
                real_str(config%steps * config%step_size)
        end if
    end subroutine resolve_steps

    !> The CSV header for n coordinates and m constraints, e.g. for n = 3, m = 1:
    !! `t,q1,q2,q3,p1,p2,p3,lambda1,H,energy_error,constraint_residual,velocity_residual,`
    !! `newton_iterations`.
    pure function csv_header(n, m) result(header)
        integer, intent(in) :: n !! number of coordinates
        integer, intent(in) :: m !! number of constraints
        character(len=:), allocatable :: header !! the header line
        ! One definition of the columns, shared with the library's trajectory_writer.
        header = trajectory_header(n, m)
    end function csv_header

    !> Run `simulate` with parsed settings: CSV to `out` (or to `config%output`), a start
    !! line, a note if any and a summary to `err_unit`. Fails with the integrator's status
    !! (rows already written are kept and flushed), or HOLOSYM_INVALID_ARGUMENT when the
    !! output file cannot be opened or a row cannot be written (full disk or device,
    !! closed standard output: the run stops there).
    subroutine run_simulate(config, out, err_unit, status, summary)
        type(simulate_config_t), intent(in) :: config  !! settings from parse_simulate_options
        type(output_t), intent(inout), target :: out   !! the CSV (unless config%output is set)
        integer, intent(in) :: err_unit  !! open unit for progress and summary
        type(holosym_status_t), intent(out) :: status  !! outcome
        type(simulate_summary_t), intent(out), optional :: summary !! counts and maxima
        class(constrained_hamiltonian), allocatable, target :: sys
        type(constrained_integrator) :: integrator
        type(csv_writer) :: writer
        type(step_info_t) :: no_step
        type(output_t), target :: file
        type(holosym_status_t) :: written
        real(wp), allocatable :: q(:), p(:)
        integer(int64) :: clock_end
        integer :: steps_done, steps, order(3)
        real(wp) :: h
        type(accuracy_plan_t) :: plan
        character(len=:), allocatable :: note

        call make_source_system(config%source, sys, q, p, status, note)
        if (.not. status%ok()) return
        if (config%plain) then
            integrator%structured = .false.
            integrator%newton%simplified = .false.
            integrator%newton%presolve = .false.
            integrator%linear_solver = "native"
            integrator%linear_increments = .false.
        end if
        if (allocated(config%iteration)) integrator%iteration = config%iteration
        if (allocated(config%sums)) integrator%residual_sums = config%sums
        order = [config%order_m, config%order_n, config%gauss_points]
        h = config%step_size
        steps = config%steps
        if (config%accuracy > 0) then
            call init_for_accuracy(integrator, sys, q, p, config%accuracy, &
                                   config%final_time, plan, status)
            if (.not. status%ok()) return
            order = [plan%order_m, plan%order_n, plan%gauss_points]
            h = plan%h
            steps = plan%steps
            write (err_unit, '(a)') "holosym simulate: --accuracy " // &
                real_str(config%accuracy) // " at T = " // real_str(config%final_time) // &
                ": estimated error " // real_str(plan%estimate) // ", Newton tolerance " // &
                real_str(plan%newton_tolerance) // " (pilot: " // int_str(plan%pilot_steps) // &
                " steps; asymptotic at h = " // real_str(plan%pilot_h) // " on [0, " // &
                real_str(plan%pilot_span) // "], ratio " // real_str(plan%observed_ratio) // &
                " for 2^(2M) = " // real_str(2.0_wp**(2 * plan%order_m)) // &
                " (0: at round-off); error measured over [0, " // &
                real_str(plan%covered_span) // "])"
        else
            call integrator%init(sys, order(1), order(2), order(3), status)
            if (.not. status%ok()) return
        end if
        writer%sink => out
        if (len(config%output) > 0) then
            call open_output(config%output, file, status)
            if (.not. status%ok()) then
                ! "cannot open 'FILE': reason" -> "cannot open --output 'FILE': reason"
                status%message = "cannot open --output " // status%message(13:)
                return
            end if
            writer%sink => file
        end if
        if (len(config%note) > 0) write (err_unit, '(a)') "holosym simulate: note: " // &
            config%note
        if (len(note) > 0) write (err_unit, '(a)') "holosym simulate: note: " // note
        write (err_unit, '(a)') "holosym simulate: " // config%source%label() // " (n = " // &
            int_str(sys%n) // ", m = " // int_str(sys%m) // "), (M, N, G) = (" // &
            int_str(order(1)) // ", " // int_str(order(2)) // ", " // int_str(order(3)) // &
            "), h = " // real_str(h) // ", " // int_str(steps) // " steps to t = " // &
            real_str(steps * h)
        flush (err_unit)

        allocate (writer%sys, source=sys)
        writer%err_unit = err_unit
        writer%every = config%every
        writer%total_steps = steps
        writer%q0 = q
        writer%p0 = p
        writer%summary%initial_energy = sys%hamiltonian(q, p)
        writer%energy_scale = writer%summary%initial_energy
        if (.not. (abs(writer%energy_scale) > 0)) then
            writer%energy_scale = 1
            write (err_unit, '(a)') "holosym simulate: note: H0 = 0, energy_error is H - H0"
        end if
        call manifold_residuals(sys, q, p, writer%position0, writer%velocity0)
        call system_clock(writer%clock_start, writer%clock_rate)
        writer%clock_last = writer%clock_start
        call writer%sink%line(csv_header(sys%n, sys%m))
        if (steps == 0) then
            allocate (no_step%lambda(sys%m, 0:0))
            no_step%lambda = ieee_value(1.0_wp, ieee_quiet_nan)
            call write_initial_row(writer, no_step)
        else if (len(config%events) > 0) then
            call run_with_events(config%events, integrator, sys, q, p, h, steps, writer, &
                                 steps_done, err_unit, status)
            writer%summary%steps_done = steps_done
        else
            call integrator%integrate(sys, q, p, h, steps, writer, steps_done, status)
            writer%summary%steps_done = steps_done
        end if
        call system_clock(clock_end)
        writer%summary%factorizations = integrator%stats%lu_factorizations
        writer%summary%approximate_iterations = integrator%stats%approximate_iterations
        writer%summary%paired_residuals = integrator%stats%paired_residual_evaluations
        writer%summary%wall_time = real(clock_end - writer%clock_start, wp) / writer%clock_rate
        ! Everything written so far reaches its file (or fails) before the summary.
        if (associated(writer%sink, file)) then
            call file%close(written)
        else
            call out%flush()
            written%code = HOLOSYM_SUCCESS
            if (out%failed()) call out%close(written)
        end if
        if (.not. written%ok()) then
            ! The rows that reached the file: complete lines written, less the header.
            writer%summary%rows = int(max(writer%sink%lines_written - 1, 0_int64))
            status%code = HOLOSYM_INVALID_ARGUMENT
            status%message = "writing the CSV failed after " // &
                int_str(writer%summary%steps_done) // " steps: " // written%message // &
                "; " // int_str(writer%summary%rows) // " complete rows reached " // &
                writer%sink%name
        end if
        call write_summary(err_unit, writer%summary)
        if (present(summary)) summary = writer%summary
    end subroutine run_simulate

    !> The run with the model's events located (`integrate_events`, the CSV writer as its
    !! observer), and the events written to `file` as CSV: event, name, direction (1
    !! rising, -1 falling), t, q1..qn, p1..pn, lambda1..lambdam, one row each in time order.
    !! A terminal event (`stop`) ends the run there (its row is the last).
    subroutine run_with_events(file, integrator, sys, q, p, h, steps, writer, steps_done, &
                               err_unit, status)
        character(len=*), intent(in) :: file
        type(constrained_integrator), intent(inout) :: integrator
        class(constrained_hamiltonian), intent(in), target :: sys
        real(wp), intent(inout) :: q(:), p(:)
        real(wp), intent(in) :: h
        integer, intent(in) :: steps, err_unit
        type(csv_writer), intent(inout) :: writer
        integer, intent(out) :: steps_done
        type(holosym_status_t), intent(out) :: status
        type(event_t), allocatable :: found(:)
        type(output_t) :: sink
        type(holosym_status_t) :: closed
        logical :: stopped
        integer :: j, i
        character(len=:), allocatable :: row
        steps_done = 0
        select type (sys)
        type is (formula_model)
            if (sys%event_count() == 0) then
                call fail(status, "option --events: the model states no event " // &
                    "(docs/events.md: event NAME: EXPR [rising|falling|any] [stop])")
                return
            end if
            call open_output(file, sink, status)
            if (.not. status%ok()) then
                status%message = "cannot open --events " // status%message(13:)
                return
            end if
            call integrate_events(integrator, sys, q, p, h, steps, model_events(sys), &
                                  found, stopped, status, steps_done, observer=writer)
            row = "event,name,direction,t,"
            call append_numbered(row, "q", sys%n, ",")
            row = row // ","
            call append_numbered(row, "p", sys%n, ",")
            if (sys%m > 0) row = row // ","
            call append_numbered(row, "lambda", sys%m, ",")
            call sink%line(row)
            do j = 1, size(found)
                row = int_str(found(j)%index) // "," // sys%event_name(found(j)%index) // &
                    "," // int_str(found(j)%direction) // "," // csv_real(found(j)%t)
                do i = 1, sys%n
                    row = row // "," // csv_real(found(j)%q(i))
                end do
                do i = 1, sys%n
                    row = row // "," // csv_real(found(j)%p(i))
                end do
                do i = 1, sys%m
                    row = row // "," // csv_real(found(j)%lambda(i))
                end do
                call sink%line(row)
            end do
            call sink%close(closed)
            if (status%ok() .and. .not. closed%ok()) status = closed
            row = ""
            if (stopped) row = " (a terminal event ended the run)"
            write (err_unit, '(a)') "holosym simulate: " // int_str(size(found)) // &
                " events written to " // file // row
        class default
            call fail(status, "option --events needs a model file (--model)")
        end select
    end subroutine run_with_events

    !> Summary line(s) of a run on standard error.
    subroutine write_summary(err_unit, summary)
        integer, intent(in) :: err_unit                  !! unit for the summary
        type(simulate_summary_t), intent(in) :: summary  !! what the run did
        character(len=32) :: seconds, mean, approximate, matrices, paired
        write (seconds, '(f16.3)') summary%wall_time
        write (approximate, '(i0)') summary%approximate_iterations
        write (matrices, '(i0)') summary%factorizations
        write (paired, '(i0)') summary%paired_residuals
        mean = "0"
        if (summary%steps_done > 0) write (mean, '(f16.2)') &
            real(summary%newton_iterations, wp) / summary%steps_done
        write (err_unit, '(a)') "holosym simulate: " // int_str(summary%steps_done) // &
            " steps, " // int_str(summary%rows) // " rows in " // trim(adjustl(seconds)) // &
            " s; Newton iterations per step " // trim(adjustl(mean)) // " (max " // &
            int_str(summary%max_newton_iterations) // "; " // trim(approximate) // &
            " without the Newton matrix, " // trim(matrices) // " Newton matrices, " // &
            trim(paired) // " residuals summed in double-double)"
        write (err_unit, '(a)') "holosym simulate: max |energy error| " // &
            real_str(summary%max_energy_error) // ", max |phi| " // &
            real_str(summary%max_end_constraint_residual) // " at the step ends (" // &
            real_str(summary%max_constraint_residual) // " over the nodes), max |Phi H_p| " // &
            real_str(summary%max_velocity_residual)
        flush (err_unit)
    end subroutine write_summary

    !> The observer binding: after step k, write the t = 0 row (at k = 1), the row of
    !! step k when k is a multiple of `every` or the last step, and update the summary.
    subroutine csv_writer_observe(self, step, t, q, p, info, halt)
        class(csv_writer), intent(inout) :: self  !! the writer
        integer, intent(in) :: step          !! step number k >= 1
        real(wp), intent(in) :: t            !! time k h
        real(wp), intent(in) :: q(:)         !! coordinates after the step
        real(wp), intent(in) :: p(:)         !! momenta after the step
        type(step_info_t), intent(in) :: info !! diagnostics of the step
        logical, intent(inout) :: halt       !! set on a write failure
        real(wp) :: energy, energy_error, elapsed
        integer(int64) :: clock_now

        if (step == 1) then
            call write_initial_row(self, info)
            if (self%sink%failed()) then
                halt = .true.
                return
            end if
        end if
        energy = self%sys%hamiltonian(q, p)
        energy_error = (energy - self%summary%initial_energy) / self%energy_scale
        associate (s => self%summary)
            s%steps_done = step
            s%max_energy_error = max(s%max_energy_error, abs(energy_error))
            s%max_constraint_residual = max(s%max_constraint_residual, info%constraint_residual)
            s%max_end_constraint_residual = max(s%max_end_constraint_residual, &
                                                info%end_constraint_residual)
            s%max_velocity_residual = max(s%max_velocity_residual, info%velocity_residual)
            s%newton_iterations = s%newton_iterations + info%newton_iterations
            s%max_newton_iterations = max(s%max_newton_iterations, info%newton_iterations)
        end associate
        if (mod(step, self%every) == 0 .or. step == self%total_steps) then
            call write_row(self, t, q, p, info%lambda(:, ubound(info%lambda, 2)), energy, &
                           energy_error, info%constraint_residual, info%velocity_residual, &
                           info%newton_iterations)
            if (self%sink%failed()) halt = .true.
        end if
        call system_clock(clock_now)
        elapsed = real(clock_now - self%clock_last, wp) / self%clock_rate
        if (elapsed >= progress_interval .and. step < self%total_steps) then
            self%clock_last = clock_now
            write (self%err_unit, '(a)') "holosym simulate: step " // int_str(step) // " of " &
                // int_str(self%total_steps) // ", t = " // real_str(t) // &
                ", max |energy error| " // real_str(self%summary%max_energy_error)
            flush (self%err_unit)
        end if
    end subroutine csv_writer_observe

    !> Write the t = 0 row: the initial state, the multipliers at the start of the first
    !! step (`info%lambda(:, 0)`), the residuals of the initial state, 0 iterations.
    subroutine write_initial_row(writer, info)
        type(csv_writer), intent(inout) :: writer !! the writer
        type(step_info_t), intent(in) :: info     !! diagnostics of the first step
        associate (s => writer%summary)
            s%max_constraint_residual = max(s%max_constraint_residual, writer%position0)
            s%max_end_constraint_residual = max(s%max_end_constraint_residual, writer%position0)
            s%max_velocity_residual = max(s%max_velocity_residual, writer%velocity0)
        end associate
        call write_row(writer, 0.0_wp, writer%q0, writer%p0, &
                       info%lambda(:, lbound(info%lambda, 2)), writer%summary%initial_energy, &
                       0.0_wp, writer%position0, writer%velocity0, 0)
    end subroutine write_initial_row

    !> Write one CSV row (a failure stays recorded in the sink).
    subroutine write_row(writer, t, q, p, lambda, energy, energy_error, position, velocity, &
                         iterations)
        type(csv_writer), intent(inout) :: writer !! the writer
        real(wp), intent(in) :: t              !! time
        real(wp), intent(in) :: q(:)           !! coordinates
        real(wp), intent(in) :: p(:)           !! momenta
        real(wp), intent(in) :: lambda(:)      !! multipliers
        real(wp), intent(in) :: energy         !! H
        real(wp), intent(in) :: energy_error   !! (H - H0)/H0
        real(wp), intent(in) :: position       !! constraint residual
        real(wp), intent(in) :: velocity       !! hidden-constraint residual
        integer, intent(in) :: iterations      !! Newton iterations
        character(len=:), allocatable :: line
        integer :: i, used

        ! Filled in place: appending field by field would copy the line once per field,
        ! which for a chain of 10^5 links (4 10^5 fields) takes minutes.
        allocate (character(len=(size(q) + size(p) + size(lambda) + 6) * 64) :: line)
        used = 0
        call put(csv_real(t))
        do i = 1, size(q)
            call put("," // csv_real(q(i)))
        end do
        do i = 1, size(p)
            call put("," // csv_real(p(i)))
        end do
        do i = 1, size(lambda)
            call put("," // csv_real(lambda(i)))
        end do
        call put("," // csv_real(energy) // "," // csv_real(energy_error) // "," // &
            csv_real(position) // "," // csv_real(velocity) // "," // csv_integer(iterations))
        call writer%sink%line(line(:used))
        if (.not. writer%sink%failed()) writer%summary%rows = writer%summary%rows + 1
    contains
        subroutine put(text)
            character(len=*), intent(in) :: text
            line(used + 1:used + len(text)) = text
            used = used + len(text)
        end subroutine put
    end subroutine write_row

    !> `holosym simulate ARGS`: parse, run, report. Usage errors and failures go to
    !! `err_unit`; `exit_code` is EXIT_OK, EXIT_FAILURE (run failed) or EXIT_USAGE.
    subroutine simulate_command(args, out, err_unit, exit_code)
        type(cli_argument_t), intent(in) :: args(:) !! arguments after "simulate"
        type(output_t), intent(inout), target :: out !! the CSV and the help
        integer, intent(in) :: err_unit   !! unit for messages
        integer, intent(out) :: exit_code !! process exit code
        type(simulate_config_t) :: config
        type(holosym_status_t) :: status

        call parse_simulate_options(args, config, status)
        if (parsed_command_proceeds("simulate", status, config%help, simulate_help(), &
                                    out, err_unit, exit_code)) then
            call run_simulate(config, out, err_unit, status)
            if (status%ok()) then
                exit_code = EXIT_OK
            else if (status%code == HOLOSYM_INVALID_ARGUMENT) then
                ! The output (file, device, standard output): its own message.
                write (err_unit, '(a)') "holosym simulate: error: " // status%message
                exit_code = EXIT_FAILURE
            else
                write (err_unit, '(a)') "holosym simulate: error: " // &
                    status_code_name(status%code) // ": " // status%message
                exit_code = EXIT_FAILURE
            end if
        end if
    end subroutine simulate_command

end module holosym_cli_simulate

!> Holds `not_installed`: fpm installs no module of a source with a submodule.
submodule (holosym_cli_simulate) holosym_cli_simulate_app
    implicit none
contains
    module procedure not_installed
    end procedure not_installed
end submodule holosym_cli_simulate_app
