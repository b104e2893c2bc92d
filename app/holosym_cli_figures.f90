!> The `figures` command: the data behind the figures of docs/figures.md, as CSV files in
!! one directory (`tools/plot_figures.py` draws them; `make figures` does both).
!!
!! The paper's figures (method.md section 5), on our own measurements:
!! - fig1_pendulum.csv: spherical pendulum, (M, N, G) = (2, 1, 3), h = 1/8, 200 s: q, p,
!!   lambda and max |phi| over each step's displacement nodes (Fig. 1);
!! - fig2_energy_M2.csv, fig2_energy_M7.csv: the same pendulum, h = 1/2, 200 s, with
!!   N = M - 1 = G - 2 = 1 and 6: the relative energy error (Fig. 2);
!! - fig4_linkage_coarse.csv (N = 1, h = 1/2) and fig4_linkage_fine.csv (N = 4, h = 1/8):
!!   the spring-linkage's balls, 20 s (Fig. 4);
!! - fig5_constraints.csv: phi_1, phi_2, phi_3 and their sum at every displacement node of
!!   the linkage run with N = 1, h = 1/2 (Fig. 5).
!! Beyond the paper:
!! - long_run.csv: energy error and constraint residuals over 10^5 steps of h = 1/8 on the
!!   pendulum for holosym (M, N, G) = (2, 1, 3) (order 4), RATTLE composed to order 4
!!   (triple jump) and the classical Runge-Kutta method on the index-1 form (order 4, not
!!   symplectic; holosym_index1, stopped when its relative energy error passes 1), each
!!   the maximum over windows of steps;
!! - convergence.csv: energy error and global error of q(10) on the pendulum against h for
!!   M = 1..8 (N = M - 1, G = M + 1), with a reference of M = 8 at a smaller step.
!! The files of the paper's figures have the columns of `holosym simulate`
!! (`trajectory_writer`). --quick shortens every run (the test suite's variant).
!!
!! The directory is made with mkdir(2), never through a shell; the trajectory files are
!! checked by the library's writer when closed, the others are written through `output_t`:
!! a full disk or device fails the command (exit 1) instead of leaving short files.
module holosym_cli_figures
    use, intrinsic :: iso_fortran_env, only: int64
    use holosym_kinds, only: wp
    use holosym_status_codes, only: holosym_status_t, int_str, real_str, status_code_name, &
        HOLOSYM_SUCCESS, HOLOSYM_INVALID_ARGUMENT
    use holosym_problem, only: constrained_hamiltonian
    use holosym_manifold, only: manifold_residuals
    use holosym_quadrature, only: gauss_lobatto
    use holosym_integrator, only: constrained_integrator, step_observer, step_info_t
    use holosym_observers, only: trajectory_writer
    use holosym_rattle, only: rattle_integrator
    use holosym_models, only: spherical_pendulum, spring_linkage
    use holosym_index1, only: rk4_step
    use holosym_cli_common, only: parsed_command_proceeds, cli_argument_t, split_option, &
        option_value, parse_integer_in, fail, csv_real, csv_integer, join_lines, EXIT_OK, &
        EXIT_FAILURE
    use holosym_output, only: output_t, open_output, make_directories
    implicit none
    private

    public :: figures_options_t, parse_figures_options, run_figures, figures_command, &
        figures_help, figure_names

    !> The figures, in the order of docs/figures.md.
    character(len=*), parameter :: figure_names(*) = [character(len=11) :: "fig1", "fig2", &
        "fig4", "fig5", "long", "convergence"]
    !> Steps of the long run (10^5 steps of h = 1/8: t = 12500), and its range.
    integer, parameter :: default_long_steps = 100000
    integer, parameter :: min_long_steps = 100, max_long_steps = 100000000
    !> Rows per method of long_run.csv (each the maximum over a window of steps).
    integer, parameter :: long_rows = 1000

    !> Options of `holosym figures`.
    type :: figures_options_t
        character(len=:), allocatable :: out_dir     !! directory of the CSV files
        logical :: figures(size(figure_names)) = .true. !! which to produce
        logical :: quick = .false.                   !! the short variant
        integer :: long_steps = default_long_steps   !! steps of the long run
        logical :: help = .false.                    !! --help given
    end type figures_options_t

    !> Records phi at every displacement node of every step (Fig. 5).
    type, extends(step_observer) :: node_recorder
        class(constrained_hamiltonian), allocatable :: sys
        real(wp), allocatable :: nodes(:)    !! displacement nodes d_0..d_M on [0, 1]
        type(output_t), pointer :: file => null() !! fig5_constraints.csv
    contains
        procedure :: observe => node_observe
    end type node_recorder

    !> Maxima over windows of steps for the long run (holosym's observer; RATTLE and the
    !! Runge-Kutta method feed `record_window` directly).
    type, extends(step_observer) :: window_recorder
        class(constrained_hamiltonian), allocatable :: sys
        character(len=:), allocatable :: method
        real(wp) :: energy0 = 0
        integer :: window = 1
        type(output_t), pointer :: file => null() !! long_run.csv
        real(wp) :: energy_max = 0, position_max = 0, velocity_max = 0
    contains
        procedure :: observe => window_observe
    end type window_recorder

    interface
        !> Does nothing. Its body, in the submodule at the end of this file, keeps this
        !! application module out of `fpm install` (see fpm.toml).
        module subroutine not_installed()
        end subroutine not_installed
    end interface

contains

    !> The text of `holosym figures --help`.
    pure function figures_help() result(text)
        character(len=:), allocatable :: text !! the help
        text = join_lines([character(len=96) :: &
            "Usage: holosym figures --out DIR [options]", &
            "", &
            "Write the data of the figures in docs/figures.md as CSV files into DIR;", &
            "tools/plot_figures.py draws them (make figures does both). Progress on stderr.", &
            "", &
            "  fig1         spherical pendulum, (M, N, G) = (2, 1, 3), h = 1/8, 200 s: q, p,", &
            "               lambda, max|phi| at the displacement nodes (paper Fig. 1)", &
            "  fig2         energy error, h = 1/2, 200 s, M = 2 and M = 7 (paper Fig. 2)", &
            "  fig4         spring-linkage balls, N = 1, h = 1/2 and N = 4, h = 1/8, 20 s", &
            "  fig5         phi1 + phi2 + phi3 at the displacement nodes, N = 1, h = 1/2", &
            "  long         energy error and constraint residuals over 10^5 steps: holosym,", &
            "               RATTLE composed to order 4, Runge-Kutta 4 on the index-1 form", &
            "  convergence  energy and global error against h, M = 1..8", &
            "", &
            "Options:", &
            "  --out DIR         directory of the CSV files (created)", &
            "  --figure LIST     comma-separated names above, or all (default all)", &
            "  --long-steps N    steps of the long run, 100..100000000 (default 100000)", &
            "  --quick           short runs (the test suite's variant): 20 s (linkage 10 s),", &
            "                    2000 long-run steps, M <= 4 and h >= 1/16 for convergence", &
            "  --help            this text"])
    end function figures_help

    !> Parse the options of `figures`. Failure: HOLOSYM_INVALID_ARGUMENT naming the option.
    subroutine parse_figures_options(args, options, status)
        type(cli_argument_t), intent(in) :: args(:)     !! the command's arguments
        type(figures_options_t), intent(out) :: options !! parsed settings
        type(holosym_status_t), intent(out) :: status   !! outcome
        character(len=:), allocatable :: name, inline, value
        logical :: has_inline, steps_given
        integer :: i
        options%out_dir = ""
        status%code = HOLOSYM_SUCCESS
        status%message = ""
        steps_given = .false.
        i = 1
        do while (i <= size(args))
            call split_option(args(i)%text, name, inline, has_inline)
            select case (name)
            case ("-h", "--help")
                options%help = .true.
                return
            case ("--quick")
                options%quick = .true.
            case ("--out", "--figure", "--long-steps")
                call option_value(args, i, name, inline, has_inline, value, status)
                if (.not. status%ok()) return
                select case (name)
                case ("--out")
                    options%out_dir = value
                case ("--figure")
                    call parse_figure_list(value, options%figures, status)
                case ("--long-steps")
                    call parse_integer_in(name, value, min_long_steps, max_long_steps, &
                                          options%long_steps, status)
                    steps_given = .true.
                end select
                if (.not. status%ok()) return
            case default
                call fail(status, "unknown option '" // args(i)%text // "'")
                return
            end select
            i = i + 1
        end do
        if (len(options%out_dir) == 0) then
            call fail(status, "option --out DIR is required")
            return
        end if
        if (options%quick .and. .not. steps_given) options%long_steps = 2000
    end subroutine parse_figures_options

    !> "fig1,long" or "all" into the selection.
    subroutine parse_figure_list(text, selected, status)
        character(len=*), intent(in) :: text
        logical, intent(out) :: selected(:)
        type(holosym_status_t), intent(inout) :: status
        integer :: first, comma, last, k
        selected = .false.
        if (text == "all") then
            selected = .true.
            return
        end if
        first = 1
        do
            comma = index(text(first:), ",")
            last = len(text)
            if (comma > 0) last = first + comma - 2
            do k = size(figure_names), 1, -1
                if (figure_names(k) == text(first:last)) exit
            end do
            if (k == 0) then
                call fail(status, "option --figure: unknown figure '" // text(first:last) // &
                    "'; choose fig1, fig2, fig4, fig5, long, convergence or all")
                return
            end if
            selected(k) = .true.
            if (comma == 0) exit
            first = first + comma
        end do
    end subroutine parse_figure_list

    !> Produce the selected CSV files in options%out_dir (created if missing).
    subroutine run_figures(options, err_unit, status)
        type(figures_options_t), intent(in) :: options !! parsed settings
        integer, intent(in) :: err_unit                !! progress lines
        type(holosym_status_t), intent(out) :: status  !! outcome
        real(wp) :: span, linkage_span
        call make_directories(options%out_dir, status)
        if (.not. status%ok()) return
        span = 200
        linkage_span = 20
        if (options%quick) then
            span = 20
            linkage_span = 10
        end if
        if (options%figures(1)) then
            call progress("fig1")
            call pendulum_run(2, 0.125_wp, span, "fig1_pendulum.csv", status)
        end if
        if (options%figures(2) .and. status%ok()) then
            call progress("fig2")
            call pendulum_run(2, 0.5_wp, span, "fig2_energy_M2.csv", status)
            if (status%ok()) call pendulum_run(7, 0.5_wp, span, "fig2_energy_M7.csv", status)
        end if
        if (options%figures(3) .and. status%ok()) then
            call progress("fig4")
            call linkage_run(2, 0.5_wp, linkage_span, "fig4_linkage_coarse.csv", status)
            if (status%ok()) call linkage_run(5, 0.125_wp, linkage_span, &
                                              "fig4_linkage_fine.csv", status)
        end if
        if (options%figures(4) .and. status%ok()) then
            call progress("fig5")
            call node_run(linkage_span, status)
        end if
        if (options%figures(5) .and. status%ok()) then
            call progress("long (" // int_str(options%long_steps) // " steps per method)")
            call long_run(options%long_steps, status)
        end if
        if (options%figures(6) .and. status%ok()) then
            call progress("convergence")
            call convergence_run(options%quick, status)
        end if

    contains

        subroutine progress(what)
            character(len=*), intent(in) :: what
            write (err_unit, '(a)') "holosym figures: " // what
            flush (err_unit)
        end subroutine progress

        function path(name) result(full)
            character(len=*), intent(in) :: name
            character(len=:), allocatable :: full
            full = options%out_dir // "/" // name
        end function path

        !> The paper's pendulum with N = M - 1 = G - 2, every step written.
        subroutine pendulum_run(order_m, h, run_span, name, status)
            integer, intent(in) :: order_m
            real(wp), intent(in) :: h, run_span
            character(len=*), intent(in) :: name
            type(holosym_status_t), intent(inout) :: status
            type(spherical_pendulum) :: sys
            real(wp) :: q(3), p(3)
            sys = spherical_pendulum()
            call sys%initial_state(q, p)
            call written_run(sys, q, p, order_m, h, nint(run_span / h), path(name), status)
        end subroutine pendulum_run

        !> The paper's spring-linkage with N = M - 1 = G - 2, every step written.
        subroutine linkage_run(order_m, h, run_span, name, status)
            integer, intent(in) :: order_m
            real(wp), intent(in) :: h, run_span
            character(len=*), intent(in) :: name
            type(holosym_status_t), intent(inout) :: status
            type(spring_linkage) :: sys
            real(wp) :: q(6), p(6)
            sys = spring_linkage()
            call sys%initial_state(q, p)
            call written_run(sys, q, p, order_m, h, nint(run_span / h), path(name), status)
        end subroutine linkage_run

        !> Fig. 5: phi at the displacement nodes of N = 1, h = 1/2 on the linkage.
        subroutine node_run(run_span, status)
            real(wp), intent(in) :: run_span
            type(holosym_status_t), intent(inout) :: status
            type(spring_linkage) :: sys
            type(constrained_integrator) :: integrator
            type(node_recorder) :: recorder
            type(output_t), target :: file
            type(holosym_status_t) :: written
            real(wp) :: q(6), p(6)
            real(wp), allocatable :: weights(:)
            sys = spring_linkage()
            call sys%initial_state(q, p)
            call integrator%init(sys, 2, 1, 3, status)
            if (.not. status%ok()) return
            allocate (recorder%sys, source=sys)
            allocate (recorder%nodes(3), weights(3))
            call gauss_lobatto(recorder%nodes, weights)
            call open_output(path("fig5_constraints.csv"), file, status)
            if (.not. status%ok()) return
            recorder%file => file
            call file%line("t,step,node,phi1,phi2,phi3,phi_sum")
            call integrator%integrate(sys, q, p, 0.5_wp, nint(run_span / 0.5_wp), recorder, &
                                      status=status)
            call file%close(written)
            if (.not. written%ok()) status = written
        end subroutine node_run

        !> The long run of the three methods on the pendulum, h = 1/8.
        subroutine long_run(steps, status)
            integer, intent(in) :: steps
            type(holosym_status_t), intent(inout) :: status
            type(spherical_pendulum) :: sys
            type(constrained_integrator) :: integrator
            type(rattle_integrator) :: rattle
            type(window_recorder) :: recorder
            type(holosym_status_t) :: breakdown, written
            type(output_t), target :: file
            real(wp), parameter :: h = 0.125_wp
            real(wp) :: q(3), p(3)
            integer :: k
            sys = spherical_pendulum()
            call open_output(path("long_run.csv"), file, status)
            if (.not. status%ok()) return
            recorder%file => file
            call file%line("method,step,t,energy_error,constraint_residual," // &
                "velocity_residual")
            allocate (recorder%sys, source=sys)
            recorder%window = max(1, steps / long_rows)
            call sys%initial_state(q, p)
            recorder%energy0 = sys%hamiltonian(q, p)
            ! holosym, order 4.
            recorder%method = "holosym"
            call integrator%init(sys, 2, 1, 3, status)
            if (status%ok()) call integrator%integrate(sys, q, p, h, steps, recorder, &
                                                       status=status)
            ! RATTLE composed to order 4.
            if (status%ok()) then
                call sys%initial_state(q, p)
                recorder%method = "rattle"
                rattle%separable = .true.
                call rattle%init(sys, 4, "triple-jump", status)
                do k = 1, steps
                    if (.not. status%ok() .or. file%failed()) exit
                    call rattle%step(sys, q, p, h, status)
                    call record_window(recorder, k, k * h, q, p)
                end do
            end if
            ! Classical Runge-Kutta on the index-1 form, order 4. Its drift off the manifold
            ! ends in an instability: the run stops when the relative energy error passes 1
            ! (or the right-hand side breaks down), which is part of what the figure shows.
            if (status%ok() .and. .not. file%failed()) then
                call sys%initial_state(q, p)
                recorder%method = "rk4-index1"
                do k = 1, steps
                    if (file%failed()) exit
                    call rk4_step(sys, q, p, h, breakdown)
                    if (breakdown%ok() .and. .not. abs(sys%hamiltonian(q, p) / &
                        recorder%energy0 - 1) <= 1) call fail(breakdown, &
                        "relative energy error above 1")
                    if (.not. breakdown%ok()) then
                        write (err_unit, '(a)') "holosym figures: rk4-index1 stopped at " // &
                            "step " // int_str(k) // ", t = " // real_str(k * h) // ": " // &
                            breakdown%message
                        exit
                    end if
                    call record_window(recorder, k, k * h, q, p)
                end do
            end if
            ! A failed write stops the run (the observer halts it): report the write.
            call file%close(written)
            if (.not. written%ok()) status = written
        end subroutine long_run

        !> Energy and global error at T = 10 against h for M = 1..8 (quick: 1..4).
        subroutine convergence_run(quick, status)
            logical, intent(in) :: quick
            type(holosym_status_t), intent(inout) :: status
            type(spherical_pendulum) :: sys
            real(wp), parameter :: run_span = 10
            real(wp) :: q_ref(3), energy_error, q_end(3), h
            real(wp), allocatable :: steps(:)
            integer :: order_m, max_m, k, reference_steps
            type(holosym_status_t) :: local
            type(output_t) :: file
            sys = spherical_pendulum()
            max_m = 8
            steps = [0.5_wp, 0.25_wp, 0.125_wp, 0.0625_wp, 0.03125_wp, 0.015625_wp]
            reference_steps = 1280
            if (quick) then
                max_m = 4
                steps = steps(1:4)
                reference_steps = 320
            end if
            call fixed_run(sys, 8, run_span / reference_steps, reference_steps, q_ref, &
                           energy_error, status)
            if (.not. status%ok()) return
            call open_output(path("convergence.csv"), file, status)
            if (.not. status%ok()) return
            call file%line("M,N,G,h,energy_error,global_error,status")
            do order_m = 1, max_m
                do k = 1, size(steps)
                    h = steps(k)
                    call fixed_run(sys, order_m, h, nint(run_span / h), q_end, energy_error, &
                                   local)
                    call file%line(int_str(order_m) // "," // int_str(order_m - 1) // &
                        "," // int_str(order_m + 1) // "," // csv_real(h) // "," // &
                        csv_real(energy_error) // "," // csv_real(maxval(abs(q_end - q_ref))) &
                        // "," // csv_integer(local%code))
                    ! Finer steps only show the round-off floor.
                    if (maxval(abs(q_end - q_ref)) < 1.0e4_wp * epsilon(1.0_wp) .and. &
                        local%ok()) exit
                end do
            end do
            call file%close(status)
            if (.not. status%ok()) return
            write (err_unit, '(a)') "holosym figures: convergence reference (M = 8, h = " // &
                "10/" // int_str(reference_steps) // ")"
        end subroutine convergence_run

    end subroutine run_figures

    !> Run (M, M-1, M+1) with the trajectory writer into `file`, every step.
    subroutine written_run(sys, q, p, order_m, h, steps, file, status)
        class(constrained_hamiltonian), intent(in) :: sys
        real(wp), intent(inout) :: q(:), p(:)
        integer, intent(in) :: order_m, steps
        real(wp), intent(in) :: h
        character(len=*), intent(in) :: file
        type(holosym_status_t), intent(inout) :: status
        type(constrained_integrator) :: integrator
        type(trajectory_writer) :: writer
        type(holosym_status_t) :: closing
        call integrator%init(sys, order_m, order_m - 1, order_m + 1, status)
        if (status%ok()) call writer%open(sys, q, p, file=file, status=status)
        if (.not. status%ok()) return
        call integrator%integrate(sys, q, p, h, steps, writer, status=status)
        call writer%close(closing)
        if (status%ok() .and. .not. closing%ok()) status = closing
    end subroutine written_run

    !> (M, M-1, M+1) from the system's start for `steps` steps: q at the end and the largest
    !! relative energy error.
    subroutine fixed_run(sys, order_m, h, steps, q_end, energy_error, status)
        type(spherical_pendulum), intent(in) :: sys
        integer, intent(in) :: order_m, steps
        real(wp), intent(in) :: h
        real(wp), intent(out) :: q_end(3), energy_error
        type(holosym_status_t), intent(out) :: status
        type(constrained_integrator) :: integrator
        real(wp) :: p(3), energy0
        integer :: k
        call sys%initial_state(q_end, p)
        energy0 = sys%hamiltonian(q_end, p)
        energy_error = 0
        call integrator%init(sys, order_m, order_m - 1, order_m + 1, status)
        if (.not. status%ok()) return
        do k = 1, steps
            call integrator%step(sys, q_end, p, h, status=status)
            if (.not. status%ok()) return
            energy_error = max(energy_error, abs((sys%hamiltonian(q_end, p) - energy0) / energy0))
        end do
    end subroutine fixed_run

    !> Fig. 5 observer: phi at the step's displacement nodes d_1..d_M (d_0 is the previous
    !! step's d_M; the first step also writes d_0), from the dense output.
    subroutine node_observe(self, step, t, q, p, info, halt)
        class(node_recorder), intent(inout) :: self
        integer, intent(in) :: step
        real(wp), intent(in) :: t, q(:), p(:)
        type(step_info_t), intent(in) :: info
        logical, intent(inout) :: halt
        real(wp) :: qn(self%sys%n), pn(self%sys%n), lambda(self%sys%m), phi(self%sys%m)
        real(wp) :: tn
        type(holosym_status_t) :: status
        integer :: i, first
        first = 2
        if (step == 1) first = 1
        do i = first, size(self%nodes)
            tn = self%dense%t_start + self%nodes(i) * (self%dense%t_end - self%dense%t_start)
            if (i == size(self%nodes)) tn = self%dense%t_end
            call self%dense%evaluate(tn, qn, pn, lambda, status)
            if (.not. status%ok()) then
                halt = .true.
                return
            end if
            call self%sys%constraint(qn, phi)
            call self%file%line(csv_real(tn) // "," // int_str(step) // "," // &
                int_str(i - 1) // "," // csv_real(phi(1)) // "," // csv_real(phi(2)) // "," // &
                csv_real(phi(3)) // "," // csv_real(sum(phi)))
            if (self%file%failed()) then
                halt = .true.
                return
            end if
        end do
    end subroutine node_observe

    !> holosym's long-run observer.
    subroutine window_observe(self, step, t, q, p, info, halt)
        class(window_recorder), intent(inout) :: self
        integer, intent(in) :: step
        real(wp), intent(in) :: t, q(:), p(:)
        type(step_info_t), intent(in) :: info
        logical, intent(inout) :: halt
        call record_window(self, step, t, q, p)
        if (self%file%failed()) halt = .true.
    end subroutine window_observe

    !> Update the window's maxima with the state after `step`; write a row at the window's
    !! end. The residuals are those of the step-end state, alike for the three methods.
    subroutine record_window(self, step, t, q, p)
        type(window_recorder), intent(inout) :: self
        integer, intent(in) :: step
        real(wp), intent(in) :: t, q(:), p(:)
        real(wp) :: position, velocity
        call manifold_residuals(self%sys, q, p, position, velocity)
        self%energy_max = max(self%energy_max, &
            abs((self%sys%hamiltonian(q, p) - self%energy0) / self%energy0))
        self%position_max = max(self%position_max, position)
        self%velocity_max = max(self%velocity_max, velocity)
        if (mod(step, self%window) == 0) then
            call self%file%line(self%method // "," // int_str(step) // "," // &
                csv_real(t) // "," // csv_real(self%energy_max) // "," // &
                csv_real(self%position_max) // "," // csv_real(self%velocity_max))
            self%energy_max = 0
            self%position_max = 0
            self%velocity_max = 0
        end if
    end subroutine record_window

    !> `holosym figures [options]`: parse, run. Exit 0 success, 1 failure, 2 usage.
    subroutine figures_command(args, out, err_unit, exit_code)
        type(cli_argument_t), intent(in) :: args(:) !! the command's arguments
        type(output_t), intent(inout) :: out !! the help
        integer, intent(in) :: err_unit   !! progress and errors
        integer, intent(out) :: exit_code !! process exit code
        type(figures_options_t) :: options
        type(holosym_status_t) :: status
        call parse_figures_options(args, options, status)
        if (.not. parsed_command_proceeds("figures", status, options%help, figures_help(), &
                                          out, err_unit, exit_code)) return
        call run_figures(options, err_unit, status)
        if (.not. status%ok()) then
            write (err_unit, '(a)') "holosym figures: error: " // &
                status_code_name(status%code) // ": " // status%message
            exit_code = EXIT_FAILURE
            return
        end if
        exit_code = EXIT_OK
    end subroutine figures_command

end module holosym_cli_figures

!> Holds `not_installed`: fpm installs no module of a source with a submodule.
submodule (holosym_cli_figures) holosym_cli_figures_app
    implicit none
contains
    module procedure not_installed
    end procedure not_installed
end submodule holosym_cli_figures_app
