!> category: internal module (use holosym)
!! Working precision of holosym.
!!
!! Every real in the library is `real(wp)`. The default is quadruple precision
!! (`real128`), as in the paper. A real64 build of the whole library is a compile-time
!! switch: define the preprocessor macro `HOLOSYM_REAL64`, e.g.
!!
!!     fpm build --profile release --flag "-DHOLOSYM_REAL64"
!!     fpm test --flag "-DHOLOSYM_REAL64"
!!
!! (`make bench64` does this). In that build Newton's linear systems go straight to
!! LAPACK's dgetrf/dgetrs and every tolerance follows epsilon(1.0_wp) = 2.2e-16.
module holosym_kinds
    use, intrinsic :: iso_fortran_env, only: real64, real128
    implicit none
    private

#ifdef HOLOSYM_REAL64
    !> Working precision: the one kind parameter used for all reals (real64 build).
    integer, parameter, public :: wp = real64
#else
    !> Working precision: the one kind parameter used for all reals.
    integer, parameter, public :: wp = real128
#endif
    !> Double precision, for the LAPACK-facing side of mixed-precision work.
    integer, parameter, public :: dp = real64
    !> True in the real64 build (wp = dp).
    logical, parameter, public :: wp_is_double = wp == dp

end module holosym_kinds
