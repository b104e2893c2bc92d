!> `holosym bench --models`: what a model file costs against the hand-written built-in
!! model of the same system, and how the cost of a chain from a model file grows with its
!! length.
!!
!! Pairs (DIR/models.csv, models64.csv in the real64 build): the spherical pendulum and the
!! spring-linkage (example/models/spherical_pendulum.hsm, spring_linkage.hsm) at (4, 3, 5)
!! and (8, 7, 9), h = 1/8, and a chain of 64 links (DIR/models/chain64.hsm, written by
!! tools/chain_model.py) at (4, 3, 5), h = 0.01, each against its built-in twin from the
!! same start: CPU seconds per step of the two, measured in alternation (7 rounds, the
!! order swapped every round), the least of each (the run least disturbed by the rest of
!! the machine) and their ratio, and the largest difference of the two final states.
!!
!! Scaling (DIR/model_scaling.csv, model_scaling64.csv): chains of K = 8 .. 256 links from
!! DIR/models/chainK.hsm at (4, 3, 5), h = 0.01: seconds to read, differentiate and
!! compile the file and to make its start (`load_seconds`), and seconds per step of the
!! model and of the built-in chain, in alternation.
module holosym_bench_models
    use, intrinsic :: iso_fortran_env, only: real64
    use holosym_kinds, only: wp, wp_is_double
    use holosym_status_codes, only: holosym_status_t, int_str, HOLOSYM_SUCCESS
    use holosym_problem, only: constrained_hamiltonian
    use holosym_integrator, only: constrained_integrator
    use holosym_formula_model, only: formula_model, load_model
    use holosym_systems, only: make_system
    use holosym_cli_common, only: csv_real
    use holosym_output, only: output_t, open_output
    implicit none
    private

    public :: run_models, models_header, model_scaling_header, model_scaling_links, &
        model_instructions_header, model_scaling_instructions_header

    !> Header of DIR/models.csv (models64.csv).
    character(len=*), parameter :: models_header = "precision,model,M,N,G,h,steps," // &
        "builtin_seconds_per_step,model_seconds_per_step,ratio,difference,status"
    !> Header of DIR/model_instructions.csv (model_instructions64.csv), written by
    !! tools/model_instructions.sh (callgrind through `holosym simulate`).
    character(len=*), parameter :: model_instructions_header = "precision,model,M,N,G,h," &
        // "steps,builtin_instructions_per_step,model_instructions_per_step,ratio"
    !> Header of DIR/model_scaling_instructions.csv (and 64), by the same script.
    character(len=*), parameter :: model_scaling_instructions_header = &
        "precision,path,links,steps,instructions_per_step"
    !> Header of DIR/model_scaling.csv (model_scaling64.csv).
    character(len=*), parameter :: model_scaling_header = "precision,path,links,n,m," // &
        "steps,seconds_per_step,load_seconds,status"

    !> One pair: a built-in system (and its links), its model file, the scheme and step.
    type :: pair_t
        character(len=16) :: name = ""
        character(len=16) :: system = ""
        integer :: links = 0
        character(len=256) :: file = ""
        integer :: orders(3) = 0
        real(wp) :: h = 0
    end type pair_t

    interface
        !> Does nothing. Its body, in the submodule at the end of this file, keeps this
        !! application module out of `fpm install` (see fpm.toml).
        module subroutine not_installed()
        end subroutine not_installed
    end interface

contains

    !> The chain lengths of the scaling part (`quick`: 8 and 16).
    pure function model_scaling_links(quick) result(links)
        logical, intent(in) :: quick !! the short variant for tests and CI
        integer, allocatable :: links(:)
        if (quick) then
            links = [8, 16]
        else
            links = [8, 16, 32, 64, 128, 256]
        end if
    end function model_scaling_links

    !> Both parts into `dir` (see the module); the chain files are read from
    !! `dir`/models/chainK.hsm. Fails with the message of a file that cannot be read or
    !! written, or of a model that does not load.
    subroutine run_models(dir, quick, err_unit, status)
        character(len=*), intent(in) :: dir     !! output directory (holds models/)
        logical, intent(in) :: quick            !! short batches, fewer rounds and chains
        integer, intent(in) :: err_unit         !! progress lines
        type(holosym_status_t), intent(out) :: status !! outcome
        type(output_t) :: out
        type(pair_t), allocatable :: pairs(:)
        character(len=:), allocatable :: suffix
        integer :: k
        suffix = merge("64.csv", ".csv  ", wp_is_double)
        pairs = [pair_t("pendulum", "pendulum", 0, "example/models/spherical_pendulum.hsm", &
                        [4, 3, 5], 0.125_wp), &
                 pair_t("pendulum", "pendulum", 0, "example/models/spherical_pendulum.hsm", &
                        [8, 7, 9], 0.125_wp), &
                 pair_t("linkage", "linkage", 0, "example/models/spring_linkage.hsm", &
                        [4, 3, 5], 0.125_wp), &
                 pair_t("linkage", "linkage", 0, "example/models/spring_linkage.hsm", &
                        [8, 7, 9], 0.125_wp), &
                 pair_t("chain64", "chain", 64, dir // "/models/chain64.hsm", [4, 3, 5], &
                        0.01_wp)]
        call open_output(dir // "/models" // trim(suffix), out, status)
        if (.not. status%ok()) return
        call out%line(models_header)
        do k = 1, size(pairs)
            write (err_unit, '(a)') "holosym bench --models: " // trim(pairs(k)%name) // &
                " (" // int_str(pairs(k)%orders(1)) // "," // int_str(pairs(k)%orders(2)) // &
                "," // int_str(pairs(k)%orders(3)) // ")"
            flush (err_unit)
            call time_pair(pairs(k), quick, out, status)
            if (.not. status%ok()) return
        end do
        call out%close(status)
        if (.not. status%ok()) return
        call open_output(dir // "/model_scaling" // trim(suffix), out, status)
        if (.not. status%ok()) return
        call out%line(model_scaling_header)
        do k = 1, size(model_scaling_links(quick))
            associate (links => model_scaling_links(quick))
                write (err_unit, '(a)') "holosym bench --models: chain of " // &
                    int_str(links(k)) // " links"
                flush (err_unit)
                call scaling_point(dir, links(k), quick, out, status)
            end associate
            if (.not. status%ok()) return
        end do
        call out%close(status)
    end subroutine run_models

    !> The model file of `pair` and its built-in twin, timed in alternation.
    subroutine time_pair(pair, quick, out, status)
        type(pair_t), intent(in) :: pair
        logical, intent(in) :: quick
        type(output_t), intent(inout) :: out
        type(holosym_status_t), intent(out) :: status
        class(constrained_hamiltonian), allocatable :: builtin
        type(formula_model) :: model
        real(wp), allocatable :: q0(:), p0(:), qa(:), pa(:), qb(:), pb(:)
        real(real64), allocatable :: seconds(:, :)
        integer :: steps, code
        if (pair%links > 0) then
            call make_system(trim(pair%system), builtin, q0, p0, status, pair%links)
        else
            call make_system(trim(pair%system), builtin, q0, p0, status)
        end if
        if (.not. status%ok()) return
        call load_model(trim(pair%file), model, status)
        if (.not. status%ok()) return
        steps = calibrated_steps(builtin, q0, p0, pair%orders, pair%h, quick)
        call alternate(builtin, model, q0, p0, pair%orders, pair%h, steps, quick, seconds, &
                       qa, pa, qb, pb, code)
        call out%line(precision_name() // "," // trim(pair%name) // "," // &
            int_str(pair%orders(1)) // "," // int_str(pair%orders(2)) // "," // &
            int_str(pair%orders(3)) // "," // csv_real(pair%h) // "," // int_str(steps) // "," &
            // csv_real(real(minval(seconds(:, 1)), wp)) // "," // &
            csv_real(real(minval(seconds(:, 2)), wp)) // "," // &
            csv_real(real(minval(seconds(:, 2)) / max(tiny(1.0_real64), &
                minval(seconds(:, 1))), wp)) // "," // &
            csv_real(max(maxval(abs(qa - qb)), maxval(abs(pa - pb)))) // "," // int_str(code))
    end subroutine time_pair

    !> One chain length of the scaling part.
    subroutine scaling_point(dir, links, quick, out, status)
        character(len=*), intent(in) :: dir
        integer, intent(in) :: links
        logical, intent(in) :: quick
        type(output_t), intent(inout) :: out
        type(holosym_status_t), intent(out) :: status
        class(constrained_hamiltonian), allocatable :: builtin
        type(formula_model) :: model
        type(holosym_status_t) :: start_status
        real(wp), allocatable :: q0(:), p0(:), qa(:), pa(:), qb(:), pb(:), qm(:), pm(:)
        real(real64), allocatable :: seconds(:, :)
        real(real64) :: start, finish
        integer :: steps, code
        integer, parameter :: orders(3) = [4, 3, 5]
        real(wp), parameter :: h = 0.01_wp
        call make_system("chain", builtin, q0, p0, status, links)
        if (.not. status%ok()) return
        call cpu_time(start)
        call load_model(dir // "/models/chain" // int_str(links) // ".hsm", model, status)
        if (status%ok()) then
            allocate (qm(model%n), pm(model%n))
            call model%initial_state(qm, pm, start_status)
        end if
        call cpu_time(finish)
        if (.not. status%ok()) then
            status%message = status%message // " (tools/chain_model.py " // int_str(links) // &
                " FILE writes it; make bench-models does)"
            return
        end if
        if (.not. start_status%ok()) then
            status = start_status
            return
        end if
        steps = calibrated_steps(builtin, q0, p0, orders, h, quick)
        call alternate(builtin, model, q0, p0, orders, h, steps, quick, seconds, qa, pa, qb, &
                       pb, code)
        call out%line(precision_name() // ",builtin," // int_str(links) // "," // &
            int_str(builtin%n) // "," // int_str(builtin%m) // "," // int_str(steps) // "," // &
            csv_real(real(minval(seconds(:, 1)), wp)) // "," // csv_real(0.0_wp) // "," // &
            int_str(code))
        call out%line(precision_name() // ",model," // int_str(links) // "," // &
            int_str(model%n) // "," // int_str(model%m) // "," // int_str(steps) // "," // &
            csv_real(real(minval(seconds(:, 2)), wp)) // "," // &
            csv_real(real(finish - start, wp)) // "," // int_str(code))
    end subroutine scaling_point

    !> Steps of a batch of the built-in system that takes about the batch time (doubled
    !! from one step until it does).
    integer function calibrated_steps(sys, q0, p0, orders, h, quick) result(steps)
        class(constrained_hamiltonian), intent(in) :: sys
        real(wp), intent(in) :: q0(:), p0(:), h
        integer, intent(in) :: orders(3)
        logical, intent(in) :: quick
        real(real64) :: seconds
        real(wp) :: q(size(q0)), p(size(p0))
        integer :: code
        steps = 1
        do
            call timed_run(sys, q0, p0, orders, h, steps, seconds, q, p, code)
            if (code /= HOLOSYM_SUCCESS .or. seconds * steps >= batch_seconds(quick) .or. &
                steps >= 2**20) exit
            steps = 2 * steps
        end do
    end function calibrated_steps

    !> CPU seconds of one batch (the target of `calibrated_steps`).
    pure real(real64) function batch_seconds(quick)
        logical, intent(in) :: quick
        batch_seconds = merge(0.02_real64, 0.3_real64, quick)
    end function batch_seconds

    !> `rounds` batches of each system in alternation (the built-in first in odd rounds):
    !! seconds(round, 1) the built-in's per step, seconds(round, 2) the model's; the final
    !! states of the last round; `code` the first failure's status (0 if none).
    subroutine alternate(builtin, model, q0, p0, orders, h, steps, quick, seconds, qa, pa, &
                         qb, pb, code)
        class(constrained_hamiltonian), intent(in) :: builtin
        type(formula_model), intent(in) :: model
        real(wp), intent(in) :: q0(:), p0(:), h
        integer, intent(in) :: orders(3), steps
        logical, intent(in) :: quick
        real(real64), allocatable, intent(out) :: seconds(:, :)
        real(wp), allocatable, intent(out) :: qa(:), pa(:), qb(:), pb(:)
        integer, intent(out) :: code
        integer :: round, rounds, c1, c2
        rounds = merge(2, 7, quick)
        allocate (seconds(rounds, 2), qa(size(q0)), pa(size(q0)), qb(size(q0)), pb(size(q0)))
        code = HOLOSYM_SUCCESS
        do round = 1, rounds
            if (mod(round, 2) == 1) then
                call timed_run(builtin, q0, p0, orders, h, steps, seconds(round, 1), qb, pb, c1)
                call timed_run(model, q0, p0, orders, h, steps, seconds(round, 2), qa, pa, c2)
            else
                call timed_run(model, q0, p0, orders, h, steps, seconds(round, 2), qa, pa, c2)
                call timed_run(builtin, q0, p0, orders, h, steps, seconds(round, 1), qb, pb, c1)
            end if
            if (code == HOLOSYM_SUCCESS) code = c1
            if (code == HOLOSYM_SUCCESS) code = c2
        end do
    end subroutine alternate

    !> CPU seconds per step of `steps` steps from (q0, p0) (set-up not timed), the end
    !! state and the status code.
    subroutine timed_run(sys, q0, p0, orders, h, steps, seconds, q, p, code)
        class(constrained_hamiltonian), intent(in) :: sys
        real(wp), intent(in) :: q0(:), p0(:), h
        integer, intent(in) :: orders(3), steps
        real(real64), intent(out) :: seconds
        real(wp), intent(out) :: q(:), p(:)
        integer, intent(out) :: code
        type(constrained_integrator) :: integ
        type(holosym_status_t) :: status
        real(real64) :: start, finish
        q = q0
        p = p0
        seconds = 0
        call integ%init(sys, orders(1), orders(2), orders(3), status)
        code = status%code
        if (.not. status%ok()) return
        call cpu_time(start)
        call integ%integrate(sys, q, p, h, steps, status=status)
        call cpu_time(finish)
        code = status%code
        seconds = (finish - start) / steps
    end subroutine timed_run

    !> "real128" or "real64".
    pure function precision_name() result(text)
        character(len=:), allocatable :: text
        text = trim(merge("real64 ", "real128", wp_is_double))
    end function precision_name

end module holosym_bench_models

!> Holds `not_installed`: fpm installs no module of a source with a submodule.
submodule (holosym_bench_models) holosym_bench_models_app
    implicit none
contains
    module procedure not_installed
    end procedure not_installed
end submodule holosym_bench_models_app
