!> The `check` command of the `holosym` tool: a system's procedures and declarations
!! compared with each other at its initial state (`check_system`), as a table, with what
!! the check costs against a step.
module holosym_cli_check
    use holosym_kinds, only: wp
    use holosym_status_codes, only: holosym_status_t, status_code_name, int_str, real_str, &
        HOLOSYM_SUCCESS
    use holosym_problem, only: constrained_hamiltonian
    use holosym_integrator, only: constrained_integrator
    use holosym_system_check, only: check_system, system_check_report_t
    use holosym_systems, only: system_source_t, make_source_system
    use holosym_output, only: output_t
    use holosym_cli_common, only: parsed_command_proceeds, cli_argument_t, split_option, &
        option_value, fail, join_lines, EXIT_OK, EXIT_FAILURE
    implicit none
    private

    public :: check_command, check_help

    !> The step whose cost the check's is compared with: `simulate`'s defaults.
    integer, parameter :: step_orders(3) = [2, 1, 3]
    real(wp), parameter :: step_size = 0.0625_wp
    !> CPU seconds over which each cost is averaged.
    real(wp), parameter :: timing_seconds = 0.2_wp

    interface
        !> Does nothing. Its body, in the submodule at the end of this file, keeps this
        !! application module out of `fpm install` (see fpm.toml).
        module subroutine not_installed()
        end subroutine not_installed
    end interface

contains

    !> The text of `holosym check --help`.
    pure function check_help() result(text)
        character(len=:), allocatable :: text !! the help
        text = join_lines([character(len=96) :: &
            "Usage: holosym check [--system NAME [--links K] | --model FILE [--set NAME=X]...]", &
            "", &
            "Compare a system's procedures and declarations with each other at its initial", &
            "state: dH/dq, dH/dp, Phi and the Hessians against differences, a declared mass", &
            "against dH/dp, declared sparsity patterns against the whole matrices, the", &
            "real64 gradient against the working-precision one (the check the integrator", &
            "runs at its first step). Markdown table on stdout, then the cost of the check", &
            "against a step of (2, 1, 3), h = 1/16.", &
            "", &
            "Options:", &
            "  --system NAME  a built-in system (see holosym simulate --help)  [pendulum]", &
            "  --links K      links of the chain (with --system chain)", &
            "  --model FILE   the system of a model file (docs/models.md)", &
            "  --set NAME=X   set parameter NAME of the model (repeatable)", &
            "  --help         this text", &
            "", &
            "Exit status: 0 every comparison passed, 1 one failed or the system could not", &
            "be set up, 2 bad usage."])
    end function check_help

    !> `holosym check ARGS`.
    subroutine check_command(args, out, err_unit, exit_code)
        type(cli_argument_t), intent(in) :: args(:) !! arguments after "check"
        type(output_t), intent(inout) :: out !! the table and the help
        integer, intent(in) :: err_unit   !! unit for messages
        integer, intent(out) :: exit_code !! process exit code
        type(system_source_t) :: source
        type(holosym_status_t) :: status
        character(len=:), allocatable :: name, inline, value
        logical :: has_inline, taken, help
        integer :: i
        help = .false.
        status%code = HOLOSYM_SUCCESS
        status%message = ""
        i = 1
        do while (i <= size(args) .and. status%ok() .and. .not. help)
            call split_option(args(i)%text, name, inline, has_inline)
            select case (name)
            case ("-h", "--help")
                help = .true.
            case ("--system", "--links", "--model", "--set")
                call option_value(args, i, name, inline, has_inline, value, status)
                if (status%ok()) call source%take(name, value, taken, status)
            case default
                call fail(status, "unknown option '" // args(i)%text // "'")
            end select
            i = i + 1
        end do
        call source%check(status)
        if (.not. parsed_command_proceeds("check", status, help, check_help(), out, &
                                          err_unit, exit_code)) return
        call run_check(source, out, err_unit, exit_code)
    end subroutine check_command

    !> Set up the system, check it, print the table and the costs.
    subroutine run_check(source, out, err_unit, exit_code)
        type(system_source_t), intent(in) :: source
        type(output_t), intent(inout) :: out
        integer, intent(in) :: err_unit
        integer, intent(out) :: exit_code
        class(constrained_hamiltonian), allocatable :: sys
        type(system_check_report_t) :: report
        type(holosym_status_t) :: status, outcome
        character(len=:), allocatable :: note
        character(len=200), allocatable :: lines(:)
        real(wp), allocatable :: q(:), p(:)
        real(wp) :: check_seconds, step_seconds
        integer :: k
        exit_code = EXIT_FAILURE
        call make_source_system(source, sys, q, p, status, note)
        if (.not. status%ok()) then
            write (err_unit, '(a)') "holosym check: error: " // status%message
            return
        end if
        if (len(note) > 0) write (err_unit, '(a)') "holosym check: note: " // note
        call check_system(sys, q, p, report, outcome)
        call out%line("### holosym check: " // source%label() // " (n = " // int_str(sys%n) // &
            ", m = " // int_str(sys%m) // "), at its initial state")
        call out%line("")
        lines = report%table()
        do k = 1, size(lines)
            call out%line(trim(lines(k)))
        end do
        call out%line("")
        check_seconds = check_cost(sys, q, p)
        step_seconds = step_cost(sys, q, p)
        if (step_seconds > 0) then
            call out%line("Cost: the check " // real_str(check_seconds) // " s, a step of " // &
                "(2, 1, 3) with h = 1/16 " // real_str(step_seconds) // " s: the check " // &
                "costs " // real_str(check_seconds / step_seconds) // " steps.")
        else
            call out%line("Cost: the check " // real_str(check_seconds) // " s (the step " // &
                "of (2, 1, 3), h = 1/16 fails here: no ratio).")
        end if
        if (outcome%ok()) then
            call out%line("Verdict: every comparison made passed.")
            exit_code = EXIT_OK
        else
            call out%line("Verdict: " // status_code_name(outcome%code) // ": " // &
                outcome%message)
            write (err_unit, '(a)') "holosym check: " // status_code_name(outcome%code) // &
                ": " // outcome%message
        end if
    end subroutine run_check

    !> CPU seconds of one check, averaged over repetitions filling `timing_seconds`.
    real(wp) function check_cost(sys, q, p) result(seconds)
        class(constrained_hamiltonian), intent(in) :: sys
        real(wp), intent(in) :: q(:), p(:)
        type(system_check_report_t) :: report
        type(holosym_status_t) :: status
        real(wp) :: start, finish
        integer :: count
        count = 0
        call cpu_time(start)
        do
            call check_system(sys, q, p, report, status)
            count = count + 1
            call cpu_time(finish)
            if (finish - start >= timing_seconds .or. count >= 100000) exit
        end do
        seconds = (finish - start) / count
    end function check_cost

    !> CPU seconds of one step from (q, p) (the check off), averaged like `check_cost`; 0
    !! when the step fails.
    real(wp) function step_cost(sys, q, p) result(seconds)
        class(constrained_hamiltonian), intent(in) :: sys
        real(wp), intent(in) :: q(:), p(:)
        type(constrained_integrator) :: integ
        type(holosym_status_t) :: status
        real(wp) :: qs(size(q)), ps(size(p)), start, finish
        integer :: count
        seconds = 0
        integ%check_system = .false.
        call integ%init(sys, step_orders(1), step_orders(2), step_orders(3), status)
        if (.not. status%ok()) return
        count = 0
        call cpu_time(start)
        do
            qs = q
            ps = p
            call integ%step(sys, qs, ps, step_size, status=status)
            if (.not. status%ok()) return
            count = count + 1
            call cpu_time(finish)
            if (finish - start >= timing_seconds .or. count >= 100000) exit
        end do
        seconds = (finish - start) / count
    end function step_cost

end module holosym_cli_check

!> Holds `not_installed`: fpm installs no module of a source with a submodule.
submodule (holosym_cli_check) holosym_cli_check_app
    implicit none
contains
    module procedure not_installed
    end procedure not_installed
end submodule holosym_cli_check_app
