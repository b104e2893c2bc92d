!> A sink of `run_ensemble` written by the user: it prints one line per trajectory as
!! the trajectory completes (on the collecting thread, one at a time).
module ensemble_printer
    use holosym, only: ensemble_sink, ensemble_result_t
    implicit none
    private

    public :: printing_sink

    !> Prints "done: id, steps, code" for each completed trajectory.
    type, extends(ensemble_sink) :: printing_sink
    contains
        procedure :: completed => print_completed
    end type printing_sink

    interface
        !> Does nothing. Its body, in the submodule at the end of this file, keeps this
        !! example module out of `fpm install` (see fpm.toml).
        module subroutine not_installed()
        end subroutine not_installed
    end interface

contains

    !> Print the trajectory's id, steps done and status code.
    subroutine print_completed(self, result, halt)
        class(printing_sink), intent(inout) :: self   !! the sink
        type(ensemble_result_t), intent(in) :: result !! the completed trajectory
        logical, intent(inout) :: halt                !! never set
        print '(a, i3, a, i0, a, i0)', "done: id", result%id, ", ", result%steps_done, &
            " steps, code ", result%code
    end subroutine print_completed

end module ensemble_printer

!> Holds `not_installed`: fpm installs no module of a source with a submodule.
submodule (ensemble_printer) ensemble_printer_example
    implicit none
contains
    module procedure not_installed
    end procedure not_installed
end submodule ensemble_printer_example
