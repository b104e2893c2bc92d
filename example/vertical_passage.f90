!> The event function of example/events.f90: g = x, the planar pendulum passes the
!! vertical.
module vertical_passage
    use holosym, only: wp, event_set
    implicit none
    private
    public :: vertical

    !> g = x: the pendulum passes the vertical.
    type, extends(event_set) :: vertical
    contains
        procedure :: count => one
        procedure :: value => x
    end type vertical

    interface
        !> Does nothing: its body, in the submodule below, keeps this example's module out
        !! of `fpm install` (fpm installs no module of a source with a submodule).
        module subroutine not_installed()
        end subroutine not_installed
    end interface

contains

    integer function one(self)
        class(vertical), intent(in) :: self
        one = 1
    end function one

    real(wp) function x(self, k, t, q, p)
        class(vertical), intent(in) :: self
        integer, intent(in) :: k
        real(wp), intent(in) :: t, q(:), p(:)
        x = q(1)
    end function x

end module vertical_passage

!> Holds `not_installed`: fpm installs no module of a source with a submodule.
submodule (vertical_passage) vertical_passage_example
    implicit none
contains
    module procedure not_installed
    end procedure not_installed
end submodule vertical_passage_example
