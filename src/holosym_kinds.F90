!> Working precision of holosym.
!!
!! Every real in the library is `real(wp)`. The default is quadruple precision
!! (`real128`), as in the paper.
module holosym_kinds
    use, intrinsic :: iso_fortran_env, only: real64, real128
    implicit none
    private

    !> Working precision: the one kind parameter used for all reals.
    integer, parameter, public :: wp = real128
    !> Double precision, for the LAPACK-facing side of mixed-precision work.
    integer, parameter, public :: dp = real64

end module holosym_kinds
