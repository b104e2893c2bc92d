!> `holosym bench --accuracy`: what `init_for_accuracy` (`--accuracy TOL`) delivers. For
!! the spherical pendulum, the spring-linkage, the planar pendulum, the double pendulum
!! and the magnetic sphere to T = 10 and requests 1e-8 .. 1e-30 (real64: 1e-6 .. 1e-12),
!! and the two pendula to T = 1000: the plan, its estimate, the error reached against a
!! reference, and the CPU seconds of the pilot and of the run. The reference is 1280 steps
!! of (8, 7, 9) to T = 10 (real64: 640 of (6, 5, 7)), 32000 to T = 1000, checked against
!! half as many steps (the difference is in the CSV file).
!! Writes DIR/accuracy.csv (accuracy64.csv) and DIR/accuracy.md (accuracy64.md).
module holosym_bench_accuracy
    use, intrinsic :: iso_fortran_env, only: real64
    use holosym_kinds, only: wp, wp_is_double
    use holosym_status_codes, only: holosym_status_t, int_str, real_str, HOLOSYM_SUCCESS
    use holosym_problem, only: constrained_hamiltonian
    use holosym_integrator, only: constrained_integrator
    use holosym_accuracy, only: accuracy_plan_t, init_for_accuracy
    use holosym_systems, only: make_system
    use holosym_study_systems, only: reference_state
    use holosym_output, only: output_t, open_output
    implicit none
    private

    public :: run_accuracy

    !> The systems of the study to T = 10, and those also run to T = 1000 (the long runs:
    !! the linear growth of the error between the span the pilot measures and T).
    character(len=*), parameter :: systems(5) = [character(len=8) :: "pendulum", "linkage", &
        "planar", "double", "magnetic"]
    character(len=*), parameter :: long_systems(2) = [character(len=8) :: "pendulum", &
        "planar"]
    real(wp), parameter :: short_span = 10, long_span = 1000

    interface
        !> Does nothing. Its body, in the submodule at the end of this file, keeps this
        !! application module out of `fpm install` (see fpm.toml).
        module subroutine not_installed()
        end subroutine not_installed
    end interface

contains

    !> The requests of this build.
    function requests() result(list)
        real(wp), allocatable :: list(:)
        if (wp_is_double) then
            list = [1.0e-6_wp, 1.0e-8_wp, 1.0e-10_wp, 1.0e-12_wp]
        else
            list = [1.0e-8_wp, 1.0e-10_wp, 1.0e-14_wp, 1.0e-18_wp, 1.0e-22_wp, 1.0e-26_wp, &
                    1.0e-30_wp]
        end if
    end function requests

    !> Run the study into `dir` (which exists); progress to `err_unit`.
    subroutine run_accuracy(dir, err_unit, status)
        character(len=*), intent(in) :: dir      !! output directory
        integer, intent(in) :: err_unit          !! progress lines
        type(holosym_status_t), intent(out) :: status !! outcome
        type(output_t) :: csv, md
        character(len=:), allocatable :: suffix
        integer :: s
        suffix = trim(merge("64", "  ", wp_is_double))
        call open_output(dir // "/accuracy" // suffix // ".csv", csv, status)
        if (.not. status%ok()) return
        call open_output(dir // "/accuracy" // suffix // ".md", md, status)
        if (.not. status%ok()) return
        call csv%line("system,precision,T,request,M,N,G,h,steps,newton_tolerance,estimate," // &
            "error,error_over_request,pilot_seconds,run_seconds,pilot_steps," // &
            "reference_difference")
        call md%line("### " // trim(merge("real64 ", "real128", wp_is_double)))
        call md%line("")
        call md%line("| system | T | request | (M,N,G) | h | steps | Newton tol | estimate | " // &
            "error at T | error / request | pilot s | run s |")
        call md%line("|---|---|---|---|---|---|---|---|---|---|---|---|")
        do s = 1, size(systems)
            call system_rows(trim(systems(s)), short_span, requests(), csv, md, err_unit, &
                             status)
            if (.not. status%ok()) return
        end do
        do s = 1, size(long_systems)
            call system_rows(trim(long_systems(s)), long_span, long_requests(), csv, md, &
                             err_unit, status)
            if (.not. status%ok()) return
        end do
        call csv%close(status)
        if (status%ok()) call md%close(status)
    end subroutine run_accuracy

    !> The requests of the long runs.
    function long_requests() result(list)
        real(wp), allocatable :: list(:)
        if (wp_is_double) then
            list = [1.0e-8_wp]
        else
            list = [1.0e-14_wp, 1.0e-20_wp, 1.0e-26_wp]
        end if
    end function long_requests

    !> The rows of one system to T = span: its reference, then every request of `list`.
    subroutine system_rows(name, span, list, csv, md, err_unit, status)
        character(len=*), intent(in) :: name
        real(wp), intent(in) :: span, list(:)
        type(output_t), intent(inout) :: csv, md
        integer, intent(in) :: err_unit
        type(holosym_status_t), intent(out) :: status
        class(constrained_hamiltonian), allocatable :: sys
        type(constrained_integrator) :: integ
        type(accuracy_plan_t) :: plan
        real(wp), allocatable :: q0(:), p0(:), q(:), p(:), q_ref(:), p_ref(:)
        real(wp) :: difference, achieved
        real(real64) :: start, planned, done
        integer :: k, steps
        call make_system(name, sys, q0, p0, status)
        if (.not. status%ok()) return
        ! 128 steps per time unit to T = 10 (real64: 64), 32 to T = 1000.
        steps = nint(span) * merge(64, 128, wp_is_double)
        if (span > short_span) steps = nint(span) * 32
        call reference_state(sys, q0, p0, span, steps, q_ref, p_ref, difference, status)
        if (.not. status%ok()) return
        do k = 1, size(list)
            q = q0
            p = p0
            call cpu_time(start)
            call init_for_accuracy(integ, sys, q, p, list(k), span, plan, status)
            call cpu_time(planned)
            if (status%ok()) call integ%integrate(sys, q, p, plan%h, plan%steps, status=status)
            call cpu_time(done)
            if (.not. status%ok()) then
                status%message = name // ", request " // real_str(list(k)) // ": " // &
                    status%message
                return
            end if
            achieved = max(maxval(abs(q - q_ref)), maxval(abs(p - p_ref)))
            call csv%line(name // "," // trim(merge("real64 ", "real128", wp_is_double)) // &
                "," // real_str(span) // "," // real_str(list(k)) // "," // &
                int_str(plan%order_m) // "," // &
                int_str(plan%order_n) // "," // int_str(plan%gauss_points) // "," // &
                real_str(plan%h) // "," // int_str(plan%steps) // "," // &
                real_str(plan%newton_tolerance) // "," // real_str(plan%estimate) // "," // &
                real_str(achieved) // "," // real_str(achieved / list(k)) // "," // &
                real_str(real(planned - start, wp)) // "," // real_str(real(done - planned, wp)) &
                // "," // int_str(plan%pilot_steps) // "," // real_str(difference))
            call md%line("| " // name // " | " // real_str(span) // " | " // &
                real_str(list(k)) // " | (" // &
                int_str(plan%order_m) // "," // int_str(plan%order_n) // "," // &
                int_str(plan%gauss_points) // ") | " // real_str(plan%h) // " | " // &
                int_str(plan%steps) // " | " // real_str(plan%newton_tolerance) // " | " // &
                real_str(plan%estimate) // " | " // real_str(achieved) // " | " // &
                real_str(achieved / list(k)) // " | " // real_str(real(planned - start, wp)) // &
                " | " // real_str(real(done - planned, wp)) // " |")
            write (err_unit, '(a)') "bench: accuracy " // name // " " // real_str(list(k)) // &
                ": error " // real_str(achieved)
        end do
    end subroutine system_rows

end module holosym_bench_accuracy

!> Holds `not_installed`: fpm installs no module of a source with a submodule.
submodule (holosym_bench_accuracy) holosym_bench_accuracy_app
    implicit none
contains
    module procedure not_installed
    end procedure not_installed
end submodule holosym_bench_accuracy_app
