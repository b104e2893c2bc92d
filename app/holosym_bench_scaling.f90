!> `holosym bench --scaling`: cost per step and memory of the chain of K planar pendula
!! (n = 2K, m = K) at (M, N, G) = (4, 3, 5), h = 0.01, for K = 1 .. 256, on the reduced
!! step (the default for systems with a diagonal mass matrix) and on the general path
!! (`structured = .false.`, dense Newton matrices) while it stays affordable.
!!
!! Each (K, path) runs in a child process (`holosym bench --scaling-point K`), so that its
!! peak resident memory (VmHWM of /proc/self/status) is its own. A point takes one step
!! (set-up, first factorisation), then doubles its step count until a batch of steps
!! takes `min_seconds` of CPU time; the cost per step is that batch's time per step.
module holosym_bench_scaling
    use, intrinsic :: iso_fortran_env, only: real64, int64
    use holosym_kinds, only: wp, wp_is_double
    use holosym_status_codes, only: holosym_status_t, int_str, HOLOSYM_SUCCESS
    use holosym_problem, only: constrained_hamiltonian
    use holosym_integrator, only: constrained_integrator
    use holosym_systems, only: make_system
    use holosym_cli_common, only: fail, csv_real
    use holosym_output, only: output_t
    use holosym_study_text, only: int64_str
    implicit none
    private

    public :: scaling_point, scaling_links, scaling_header, general_links_limit, &
              peak_memory_kb

    !> The scheme and step of the study.
    integer, parameter :: order_m = 4, order_n = 3, gauss_points = 5
    real(wp), parameter :: step_size = 0.01_wp
    !> Header of DIR/scaling.csv (scaling64.csv in the real64 build).
    character(len=*), parameter :: scaling_header = &
        "precision,path,links,n,m,steps,seconds_per_step,max_rss_kb,status"

    interface
        !> Does nothing. Its body, in the submodule at the end of this file, keeps this
        !! application module out of `fpm install` (see fpm.toml).
        module subroutine not_installed()
        end subroutine not_installed
    end interface

contains

    !> The chain lengths of the study (`quick`: 1 .. 8).
    pure function scaling_links(quick) result(links)
        logical, intent(in) :: quick !! the short variant for tests
        integer, allocatable :: links(:)
        if (quick) then
            links = [1, 2, 4, 8]
        else
            links = [1, 2, 4, 8, 16, 32, 64, 100, 128, 256]
        end if
    end function scaling_links

    !> Largest K run on the general path.
    pure integer function general_links_limit(quick)
        logical, intent(in) :: quick !! the short variant for tests
        general_links_limit = merge(4, 64, quick)
    end function general_links_limit

    !> Peak resident memory of this process in kB (VmHWM), -1 where /proc is missing.
    function peak_memory_kb() result(kb)
        integer(int64) :: kb
        character(len=256) :: line
        integer :: unit, ios
        kb = -1
        open (newunit=unit, file="/proc/self/status", status="old", action="read", iostat=ios)
        if (ios /= 0) return
        do
            read (unit, '(a)', iostat=ios) line
            if (ios /= 0) exit
            if (index(line, "VmHWM:") == 1) then
                read (line(7:), *, iostat=ios) kb
                if (ios /= 0) kb = -1
                exit
            end if
        end do
        close (unit)
    end function peak_memory_kb

    !> Time the chain of `links` links on one path and write its CSV line (no header)
    !! to `out`. Failure of the integrator: the line carries its status code.
    subroutine scaling_point(links, general, quick, out, status)
        integer, intent(in) :: links    !! K
        logical, intent(in) :: general  !! the general path instead of the reduced step
        logical, intent(in) :: quick    !! short timing batches
        type(output_t), intent(inout) :: out !! CSV line
        type(holosym_status_t), intent(out) :: status !! failure to set up the system
        class(constrained_hamiltonian), allocatable :: sys
        type(constrained_integrator) :: integ
        type(holosym_status_t) :: run_status
        real(wp), allocatable :: q(:), p(:)
        real(real64) :: start, finish, min_seconds, per_step
        integer :: steps, batch

        call make_system("chain", sys, q, p, status, links)
        if (.not. status%ok()) return
        min_seconds = merge(0.05_real64, 1.0_real64, quick)
        integ%structured = .not. general
        call integ%init(sys, order_m, order_n, gauss_points, run_status)
        steps = 0
        per_step = 0
        if (run_status%ok()) call integ%integrate(sys, q, p, step_size, 1, status=run_status)
        batch = 1
        do while (run_status%ok())
            call cpu_time(start)
            call integ%integrate(sys, q, p, step_size, batch, status=run_status)
            call cpu_time(finish)
            if (.not. run_status%ok()) exit
            steps = batch
            per_step = (finish - start) / batch
            if (finish - start >= min_seconds .or. batch >= 2**20) exit
            batch = 2 * batch
        end do
        call out%line(trim(merge("real64 ", "real128", wp_is_double)) // "," // &
            trim(merge("general", "reduced", general)) // "," // int_str(links) // "," // &
            int_str(sys%n) // "," // int_str(sys%m) // "," // int_str(steps) // "," // &
            csv_real(real(per_step, wp)) // "," // int64_str(peak_memory_kb()) // "," // &
            int_str(run_status%code))
    end subroutine scaling_point

end module holosym_bench_scaling

!> Holds `not_installed`: fpm installs no module of a source with a submodule.
submodule (holosym_bench_scaling) holosym_bench_scaling_app
    implicit none
contains
    module procedure not_installed
    end procedure not_installed
end submodule holosym_bench_scaling_app
