!> `holosym bench --long`: long runs, where the method's structure should pay: the planar
!! pendulum to T = 10^4 and 10^5 and the spherical pendulum to T = 10^4 (real128).
!!
!! Per case: a reference q(T), p(T) from holosym (8,7,9) at h = 1/16 and 1/32 (its error
!! estimated from their difference / (2^16 - 1)); holosym (6,5,7) and (8,7,9) with h
!! halved from 1 until the error at T is below the smallest target; the cheapest run of
!! each configuration reaching each target (1e-20, 1e-24) is then run again, untimed,
!! with the whole-run max |phi|, max |Phi H_p| and energy error measured after every
!! step. Then, as `holosym simulate --accuracy TARGET --T T` runs it, holosym through
!! `init_for_accuracy` for each target (method holosym-accuracy: seconds the pilot and
!! the run together, compile_seconds the pilot; monitored again untimed). With --heyoka PYTHON, tools/heyoka_bench.py runs the index-1 form over a sweep
!! of tolerances on the same reference. Rows go to DIR/long.csv, rewritten through
!! `output_t` after each row (so that a full disk fails the command and an interrupted
!! run keeps its rows); heyoka's rows come through a scratch file, checked, and Python
!! runs without a shell (`run_program`).
!! The sweep of (8,7,9) stops above the reference's coarser step (h_ref), where its error
!! could no longer be told from the reference's.
!! `--quick` (tests): T = 20 and 10, references at h = 1/8 and 1/16, heyoka at 1e-20 and
!! 1e-24 only.
module holosym_bench_long
    use, intrinsic :: iso_fortran_env, only: real64
    use holosym_kinds, only: wp, wp_is_double
    use holosym_status_codes, only: holosym_status_t, int_str, real_str, real_field, HOLOSYM_SUCCESS
    use holosym_problem, only: constrained_hamiltonian
    use holosym_integrator, only: constrained_integrator, step_observer, step_info_t
    use holosym_accuracy, only: accuracy_plan_t, init_for_accuracy
    use holosym_manifold, only: manifold_residuals
    use holosym_systems, only: make_system
    use holosym_cli_common, only: fail, csv_real
    use holosym_output, only: output_t, open_output, remove_file, run_program, &
        command_text, text_t, read_text_file, append_text, write_lines
    implicit none
    private

    public :: run_long, long_header, long_targets

    !> Header of DIR/long.csv (tools/heyoka_bench.py writes the same columns).
    character(len=*), parameter :: long_header = "system,method,precision,span,config," // &
        "tolerance,steps,error,max_phi,max_hidden,energy_error,seconds,compile_seconds,status"
    !> Error targets at T.
    real(wp), parameter :: long_targets(2) = [1.0e-20_wp, 1.0e-24_wp]
    !> holosym configurations of the sweep: (M, N, G) columns.
    integer, parameter :: configs(3, 2) = reshape([6, 5, 7, 8, 7, 9], [3, 2])
    !> heyoka tolerances of the sweep.
    character(len=*), parameter :: heyoka_tolerances = &
        "1e-22,1e-24,1e-26,1e-27,1e-28,1e-29,1e-30,1e-31,1e-32,1e-33"
    character(len=*), parameter :: heyoka_tolerances_quick = "1e-20,1e-24"

    !> Whole-run monitor: max |phi|, max |Phi H_p|, max |(H - H0)/H0| after every step.
    type, extends(step_observer) :: run_monitor
        class(constrained_hamiltonian), allocatable :: sys
        real(wp) :: energy0 = 0, max_phi = 0, max_hidden = 0, energy_error = 0
    contains
        procedure :: observe => monitor_observe
    end type run_monitor

    interface
        !> Does nothing. Its body, in the submodule at the end of this file, keeps this
        !! application module out of `fpm install` (see fpm.toml).
        module subroutine not_installed()
        end subroutine not_installed
    end interface

contains

    subroutine monitor_observe(self, step, t, q, p, info, halt)
        class(run_monitor), intent(inout) :: self
        integer, intent(in) :: step
        real(wp), intent(in) :: t, q(:), p(:)
        type(step_info_t), intent(in) :: info
        logical, intent(inout) :: halt
        real(wp) :: position, velocity
        call manifold_residuals(self%sys, q, p, position, velocity)
        self%max_phi = max(self%max_phi, position, info%constraint_residual)
        self%max_hidden = max(self%max_hidden, velocity)
        self%energy_error = max(self%energy_error, &
            abs((self%sys%hamiltonian(q, p) - self%energy0) / self%energy0))
    end subroutine monitor_observe

    !> One holosym run to T: CPU seconds (no monitor), error at T; with `diagnose`, a
    !! second, monitored run for the whole-run residuals.
    subroutine one_run(sys, q0, p0, span, config, h, q_ref, p_ref, diagnose, seconds, &
                       error, monitor, status, q_end, p_end)
        class(constrained_hamiltonian), intent(in) :: sys
        real(wp), intent(in) :: q0(:), p0(:), span, h, q_ref(:), p_ref(:)
        integer, intent(in) :: config(3)
        logical, intent(in) :: diagnose
        real(real64), intent(out) :: seconds
        real(wp), intent(out) :: error
        type(run_monitor), intent(inout) :: monitor
        type(holosym_status_t), intent(out) :: status
        real(wp), intent(out), optional :: q_end(:), p_end(:)
        type(constrained_integrator) :: integ
        real(wp) :: q(size(q0)), p(size(p0))
        real(real64) :: start, finish
        integer :: steps
        steps = nint(span / h)
        q = q0
        p = p0
        seconds = 0
        error = huge(1.0_wp)
        call integ%init(sys, config(1), config(2), config(3), status)
        if (.not. status%ok()) return
        call cpu_time(start)
        call integ%integrate(sys, q, p, span / steps, steps, status=status)
        call cpu_time(finish)
        if (.not. status%ok()) return
        seconds = finish - start
        error = max(maxval(abs(q - q_ref)), maxval(abs(p - p_ref)))
        if (present(q_end)) q_end = q
        if (present(p_end)) p_end = p
        if (.not. diagnose) return
        q = q0
        p = p0
        monitor%energy0 = sys%hamiltonian(q0, p0)
        monitor%max_phi = 0
        monitor%max_hidden = 0
        monitor%energy_error = 0
        call integ%init(sys, config(1), config(2), config(3), status)
        call integ%integrate(sys, q, p, span / steps, steps, observer=monitor, status=status)
    end subroutine one_run

    !> The long runs into DIR/long.csv (replaced). `python`: interpreter with heyoka, or "".
    subroutine run_long(dir, python, quick, err_unit, status)
        character(len=*), intent(in) :: dir    !! output directory
        character(len=*), intent(in) :: python !! heyoka's Python ("" = holosym only)
        logical, intent(in) :: quick           !! the short variant for tests
        integer, intent(in) :: err_unit        !! progress
        type(holosym_status_t), intent(inout) :: status !! I/O or set-up failure
        ! The longest case last: an interrupted run keeps the rows of the others.
        character(len=8), parameter :: systems(3) = [character(len=8) :: "planar", &
                                                     "pendulum", "planar"]
        real(wp) :: spans(3), span, h_ref, change, h, error, best(2), previous
        class(constrained_hamiltonian), allocatable :: sys
        real(wp), allocatable :: q0(:), p0(:), q_ref(:), p_ref(:), q1(:), p1(:)
        type(run_monitor) :: monitor
        type(holosym_status_t) :: run_status
        real(real64) :: seconds
        integer :: c, k, level, t
        type(text_t), allocatable :: lines(:)
        character(len=:), allocatable :: reference_path, out_path

        if (wp_is_double) then
            call fail(status, "the long runs need the real128 build (targets 1e-20, 1e-24)")
            return
        end if
        if (quick) then
            spans = [20.0_wp, 10.0_wp, 20.0_wp]
            h_ref = 0.125_wp
        else
            spans = [1.0e4_wp, 1.0e4_wp, 1.0e5_wp]
            h_ref = 0.0625_wp
        end if
        out_path = dir // "/long.csv"
        reference_path = dir // "/long_reference.csv"
        allocate (lines(0))
        call append_text(lines, long_header)
        call write_lines(out_path, lines, status)
        if (.not. status%ok()) return
        do c = 1, size(systems)
            if (quick .and. c == 3) cycle
            span = spans(c)
            call make_system(trim(systems(c)), sys, q0, p0, status)
            if (.not. status%ok()) return
            allocate (monitor%sys, source=sys)
            allocate (q_ref(size(q0)), p_ref(size(p0)), q1(size(q0)), p1(size(p0)))
            ! Reference: (8,7,9) at h_ref and h_ref / 2.
            call one_run(sys, q0, p0, span, configs(:, 2), h_ref, q0, p0, .false., seconds, &
                         error, monitor, status, q1, p1)
            if (status%ok()) call one_run(sys, q0, p0, span, configs(:, 2), h_ref / 2, q0, &
                p0, .false., seconds, error, monitor, status, q_ref, p_ref)
            if (.not. status%ok()) return
            change = max(maxval(abs(q1 - q_ref)), maxval(abs(p1 - p_ref)))
            write (err_unit, '(a)') "bench --long: " // trim(systems(c)) // " T = " // &
                real_str(span) // ": reference (8,7,9) h = " // real_str(h_ref / 2) // &
                ", estimated error " // real_str(change / (2.0_wp**16 - 1))
            call write_reference(reference_path, trim(systems(c)), q0, p0, q_ref, p_ref, &
                                 change / (2.0_wp**16 - 1), status)
            if (.not. status%ok()) return
            do k = 1, size(configs, 2)
                best = -1
                h = 1
                previous = huge(1.0_wp)
                do level = 0, 12
                    ! The reference's own configuration and step cannot be measured by it.
                    if (k == 2 .and. h <= h_ref) exit
                    call one_run(sys, q0, p0, span, configs(:, k), h, q_ref, p_ref, .false., &
                                 seconds, error, monitor, run_status)
                    write (err_unit, '(a)') "bench --long: " // trim(systems(c)) // " (" // &
                        config_text(configs(:, k)) // ") h = " // real_str(h) // ": error " // &
                        real_str(error) // ", " // real_str(real(seconds, wp)) // " s"
                    if (run_status%ok()) then
                        do t = 1, size(long_targets)
                            if (best(t) < 0 .and. error <= long_targets(t)) then
                                best(t) = h
                                call record(h)
                                if (.not. status%ok()) return
                            end if
                        end do
                    end if
                    if (all(best > 0)) exit
                    if (.not. (run_status%ok() .and. error < previous / 2)) exit  ! no gain
                    previous = error
                    h = h / 2
                end do
            end do
            do t = 1, size(long_targets)
                call record_accuracy(long_targets(t))
                if (.not. status%ok()) return
            end do
            if (len(python) > 0) then
                call heyoka_long(trim(systems(c)))
                if (.not. status%ok()) return
            end if
            deallocate (monitor%sys, q_ref, p_ref, q1, p1)
        end do

    contains

        !> Run (config k, h) again with the monitor and append its row.
        subroutine record(step)
            real(wp), intent(in) :: step
            real(real64) :: timed
            real(wp) :: timed_error
            call one_run(sys, q0, p0, span, configs(:, k), step, q_ref, p_ref, .true., &
                         timed, timed_error, monitor, run_status)
            call append_text(lines, trim(systems(c)) // ",holosym,real128," // &
                trim(real_field(span)) // ",(" // config_text(configs(:, k)) // ") h=" // &
                trim(real_str(step)) // ",0," // int_str(nint(span / step)) // "," // &
                csv_real(error) // "," // csv_real(monitor%max_phi) // "," // &
                csv_real(monitor%max_hidden) // "," // csv_real(monitor%energy_error) // "," &
                // csv_real(real(seconds, wp)) // ",0," // int_str(run_status%code))
            call write_lines(out_path, lines, status)
        end subroutine record

        !> holosym through `init_for_accuracy` to `target` at T: the pilot and the run
        !! timed, then the plan's run again (a copy of the integrator as planned) with the
        !! monitor; its row appended.
        subroutine record_accuracy(target)
            real(wp), intent(in) :: target
            type(constrained_integrator) :: integ, planned
            type(accuracy_plan_t) :: plan
            real(wp) :: q(size(q0)), p(size(p0)), run_error
            real(real64) :: start, chosen, finish
            q = q0
            p = p0
            run_error = huge(1.0_wp)
            monitor%energy0 = sys%hamiltonian(q0, p0)
            monitor%max_phi = 0
            monitor%max_hidden = 0
            monitor%energy_error = 0
            call cpu_time(start)
            call init_for_accuracy(integ, sys, q, p, target, span, plan, run_status)
            call cpu_time(chosen)
            planned = integ
            if (run_status%ok()) call integ%integrate(sys, q, p, plan%h, plan%steps, &
                                                      status=run_status)
            call cpu_time(finish)
            if (run_status%ok()) then
                run_error = max(maxval(abs(q - q_ref)), maxval(abs(p - p_ref)))
                q = q0
                p = p0
                call planned%integrate(sys, q, p, plan%h, plan%steps, observer=monitor, &
                                       status=run_status)
            end if
            write (err_unit, '(a)') "bench --long: " // trim(systems(c)) // " --accuracy " // &
                real_str(target) // ": (" // int_str(plan%order_m) // " " // &
                int_str(plan%order_n) // " " // int_str(plan%gauss_points) // ") h = " // &
                real_str(plan%h) // ", error " // real_str(run_error) // ", max |phi| " // &
                real_str(monitor%max_phi) // ", pilot " // real_str(real(chosen - start, wp)) &
                // " s, run " // real_str(real(finish - chosen, wp)) // " s"
            call append_text(lines, trim(systems(c)) // ",holosym-accuracy,real128," // &
                trim(real_field(span)) // ",(" // int_str(plan%order_m) // " " // &
                int_str(plan%order_n) // " " // int_str(plan%gauss_points) // ") h=" // &
                trim(real_str(plan%h)) // "," // csv_real(target) // "," // &
                int_str(plan%steps) // "," // csv_real(run_error) // "," // &
                csv_real(monitor%max_phi) // "," // csv_real(monitor%max_hidden) // "," // &
                csv_real(monitor%energy_error) // "," // csv_real(real(finish - start, wp)) &
                // "," // csv_real(real(chosen - start, wp)) // "," // int_str(run_status%code))
            call write_lines(out_path, lines, status)
        end subroutine record_accuracy

        !> heyoka's long runs of a case: tools/heyoka_bench.py (no shell) writes its rows
        !! to a scratch file; each must have the columns of long.csv and be heyoka's row of
        !! this system; they are added to long.csv.
        subroutine heyoka_long(system)
            character(len=*), intent(in) :: system
            type(text_t), allocatable :: argv(:), part_lines(:)
            character(len=:), allocatable :: part
            integer :: exit_code, row
            part = out_path // ".heyoka"
            call remove_file(part, status)
            if (.not. status%ok()) return
            allocate (argv(0))
            call append_text(argv, python)
            call append_text(argv, "tools/heyoka_bench.py")
            call append_text(argv, "long")
            call append_text(argv, "--system")
            call append_text(argv, system)
            call append_text(argv, "--span")
            call append_text(argv, trim(real_field(span)))
            call append_text(argv, "--reference")
            call append_text(argv, reference_path)
            call append_text(argv, "--out")
            call append_text(argv, part)
            call append_text(argv, "--tolerances")
            if (quick) then
                call append_text(argv, heyoka_tolerances_quick)
            else
                call append_text(argv, heyoka_tolerances)
            end if
            write (err_unit, '(a)') "bench --long: " // command_text(argv)
            call run_program(argv, "", exit_code, status)
            if (.not. status%ok()) then
                status%message = "heyoka long runs could not be started: " // status%message
                return
            end if
            if (exit_code /= 0) then
                call fail(status, "heyoka long runs failed (exit status " // &
                    int_str(exit_code) // "): " // command_text(argv))
                return
            end if
            call read_text_file(part, part_lines, status)
            if (.not. status%ok()) return
            if (size(part_lines) == 0) then
                call fail(status, part // ": no header")
                return
            else if (part_lines(1)%text /= long_header) then
                call fail(status, part // ": line 1 is not the header of long.csv")
                return
            end if
            do row = 2, size(part_lines)
                if (count_commas(part_lines(row)%text) /= count_commas(long_header) .or. &
                    index(part_lines(row)%text, system // ",heyoka,real128,") /= 1) then
                    call fail(status, part // ": line " // int_str(row) // " is not a " // &
                        "row of heyoka's long runs of " // system // " with the columns " // &
                        "of long.csv")
                    return
                end if
            end do
            do row = 2, size(part_lines)
                call append_text(lines, part_lines(row)%text)
            end do
            call write_lines(out_path, lines, status)
            if (status%ok()) call remove_file(part, status)
        end subroutine heyoka_long

    end subroutine run_long

    pure function config_text(config) result(text)
        integer, intent(in) :: config(3)
        character(len=:), allocatable :: text
        text = int_str(config(1)) // " " // int_str(config(2)) // " " // int_str(config(3))
    end function config_text

    !> Write the initial and reference states of a case (the format of reference.csv)
    !! to `path` (replaced: it holds the case being run).
    subroutine write_reference(path, system, q0, p0, q_ref, p_ref, accuracy, status)
        character(len=*), intent(in) :: path, system
        real(wp), intent(in) :: q0(:), p0(:), q_ref(:), p_ref(:), accuracy
        type(holosym_status_t), intent(inout) :: status
        type(output_t) :: file
        integer :: k
        call open_output(path, file, status)
        if (.not. status%ok()) return
        call file%line("# " // system // ": estimated error of the reference " // &
            real_str(accuracy))
        do k = 1, size(q0)
            call file%line(system // ",q0," // int_str(k) // "," // csv_real(q0(k)))
        end do
        do k = 1, size(p0)
            call file%line(system // ",p0," // int_str(k) // "," // csv_real(p0(k)))
        end do
        do k = 1, size(q_ref)
            call file%line(system // ",q," // int_str(k) // "," // csv_real(q_ref(k)))
        end do
        do k = 1, size(p_ref)
            call file%line(system // ",p," // int_str(k) // "," // csv_real(p_ref(k)))
        end do
        call file%close(status)
    end subroutine write_reference

    !> Commas in a line.
    pure integer function count_commas(line)
        character(len=*), intent(in) :: line
        integer :: k
        count_commas = 0
        do k = 1, len(line)
            if (line(k:k) == ",") count_commas = count_commas + 1
        end do
    end function count_commas

end module holosym_bench_long

!> Holds `not_installed`: fpm installs no module of a source with a submodule.
submodule (holosym_bench_long) holosym_bench_long_app
    implicit none
contains
    module procedure not_installed
    end procedure not_installed
end submodule holosym_bench_long_app
