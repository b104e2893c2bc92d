!> category: internal module (use holosym)
!! Dense linear algebra in working precision: LU factorisation with partial pivoting
!! and the matching solve, in the style of LAPACK's getrf/getrs.
!!
!! Reference LAPACK has no real128 routines, so these are written here. A pivot whose
!! magnitude is at most `tolerance * max|A|` (default `default_pivot_tolerance(n)` =
!! n * epsilon) marks the matrix as singular to working precision.
!!
!! `lu_factor_dp`/`lu_solve_dp` are the real64 counterparts: they call LAPACK (dgetrf,
!! dlaswp + BLAS dtrsv, dgetrs) through explicit interfaces with real64 arrays (never
!! real128 data). At the orders of typical Newton systems the per-call overhead of the
!! BLAS routines dominates the arithmetic, so below `small_lu_size` the factorisation is
!! our own loops (`small_lu`, LAPACK's conventions) and one right-hand side below
!! `blas_solve_size` is solved by plain substitution loops.
!! Newton uses them for mixed precision (a real64 factorisation, real128 residuals) and,
!! in the real64 build, for everything. The LAPACK/BLAS calls run one thread at a time
!! (an OpenMP critical section): a serial OpenBLAS is not safe for concurrent calls.
module holosym_linalg
    ! IEEE classification of the entries: no ordered comparison ever sees a NaN.
    use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
    use holosym_kinds, only: wp, dp
    implicit none
    private

    public :: lu_factor, lu_solve, default_pivot_tolerance
    public :: lu_factor_dp, lu_solve_dp, default_pivot_tolerance_dp

    !> Below this order `lu_factor_dp` factors with its own loops (`small_lu`): the per-column
    !! BLAS calls of LAPACK's unblocked dgetf2 cost more than the arithmetic there (about 6
    !! times the instructions at n = 25); from it on, LAPACK's blocked dgetrf.
    integer, parameter :: small_lu_size = 32
    !> From this order on one right-hand side is solved with BLAS dtrsv.
    integer, parameter :: blas_solve_size = 64

    interface
        !> LAPACK: row interchanges of a matrix.
        subroutine dlaswp(n, a, lda, k1, k2, ipiv, incx)
            import :: dp
            integer, intent(in) :: n      !! columns of a
            integer, intent(in) :: lda    !! leading dimension of a
            real(dp), intent(inout) :: a(lda, *) !! matrix, rows interchanged in place
            integer, intent(in) :: k1     !! first interchange to apply
            integer, intent(in) :: k2     !! last interchange to apply
            integer, intent(in) :: ipiv(*)      !! pivot indices
            integer, intent(in) :: incx   !! 1: apply k1..k2 in order
        end subroutine dlaswp

        !> BLAS: triangular solve with one right-hand side.
        subroutine dtrsv(uplo, trans, diag, n, a, lda, x, incx)
            import :: dp
            character(len=1), intent(in) :: uplo  !! 'L' or 'U'
            character(len=1), intent(in) :: trans !! 'N': A x = b
            character(len=1), intent(in) :: diag  !! 'U': unit diagonal, 'N' not
            integer, intent(in) :: n      !! order
            integer, intent(in) :: lda    !! leading dimension of a
            real(dp), intent(in) :: a(lda, *)   !! triangular matrix
            real(dp), intent(inout) :: x(*)     !! right-hand side in, solution out
            integer, intent(in) :: incx   !! stride of x
        end subroutine dtrsv

        !> LAPACK: LU factorisation of a real64 general matrix.
        subroutine dgetrf(m, n, a, lda, ipiv, info)
            import :: dp
            integer, intent(in) :: m      !! rows
            integer, intent(in) :: n      !! columns
            integer, intent(in) :: lda    !! leading dimension of a
            real(dp), intent(inout) :: a(lda, *) !! matrix in, factors out
            integer, intent(out) :: ipiv(*)     !! pivot indices
            integer, intent(out) :: info        !! 0, -i bad argument i, i > 0 zero pivot
        end subroutine dgetrf

        !> LAPACK: solve with the factors of dgetrf.
        subroutine dgetrs(trans, n, nrhs, a, lda, ipiv, b, ldb, info)
            import :: dp
            character(len=1), intent(in) :: trans !! 'N': A x = b
            integer, intent(in) :: n      !! order
            integer, intent(in) :: nrhs   !! right-hand sides
            integer, intent(in) :: lda    !! leading dimension of a
            real(dp), intent(in) :: a(lda, *)   !! factors
            integer, intent(in) :: ipiv(*)      !! pivots
            integer, intent(in) :: ldb    !! leading dimension of b
            real(dp), intent(inout) :: b(ldb, *) !! right-hand sides in, solutions out
            integer, intent(out) :: info        !! 0 or -i for a bad argument i
        end subroutine dgetrs
    end interface

contains

    !> Relative pivot threshold used when none is given: n * epsilon(1.0_wp).
    pure real(wp) function default_pivot_tolerance(n)
        integer, intent(in) :: n !! matrix order
        default_pivot_tolerance = max(n, 1) * epsilon(1.0_wp)
    end function default_pivot_tolerance

    !> LU factorisation P A = L U with partial (row) pivoting, in place.
    !!
    !! `info`: 0 success; -1 `a` not square; -2 `pivots` too short; -4 `tolerance` not
    !! finite; k > 0 when the k-th pivot is at most `tolerance * max|A|` (singular to working
    !! precision; the factors are then incomplete and must not be used), or when column k is
    !! the first with a NaN or infinite entry. All-zero and empty matrices: see below.
    pure subroutine lu_factor(a, pivots, info, tolerance, pivot_ratio)
        real(wp), intent(inout) :: a(:, :)  !! on entry A (n x n); on exit L (unit, below) and U
        integer, intent(out) :: pivots(:)   !! row interchanges: row k was swapped with pivots(k)
        integer, intent(out) :: info        !! 0, a negative argument index, or the singular step
        real(wp), intent(in), optional :: tolerance   !! relative pivot threshold
        real(wp), intent(out), optional :: pivot_ratio !! min |pivot| / max|A| (0 when singular)
        integer :: n, k, p, i
        real(wp) :: scale, threshold, smallest, row(size(a, 2))

        n = size(a, 1)
        if (present(pivot_ratio)) pivot_ratio = 0
        info = argument_info(n, size(a, 2), size(pivots))
        if (info /= 0) return
        if (present(tolerance)) then
            if (.not. ieee_is_finite(tolerance)) then
                info = -4
                return
            end if
        end if
        if (n == 0) then
            if (present(pivot_ratio)) pivot_ratio = 1
            return
        end if
        ! A NaN or infinite entry: singular at the first column holding one.
        do k = 1, n
            if (.not. all(ieee_is_finite(a(:, k)))) then
                info = k
                return
            end if
        end do
        scale = maxval(abs(a))
        if (present(tolerance)) then
            threshold = tolerance * scale
        else
            threshold = default_pivot_tolerance(n) * scale
        end if
        smallest = huge(1.0_wp)
        do k = 1, n
            p = k - 1 + maxloc(abs(a(k:n, k)), dim=1)
            pivots(k) = p
            if (.not. (abs(a(p, k)) > threshold)) then
                ! Also catches scale == 0 and NaN entries.
                info = k
                return
            end if
            smallest = min(smallest, abs(a(p, k)))
            if (p /= k) then
                row = a(k, :)
                a(k, :) = a(p, :)
                a(p, :) = row
            end if
            a(k + 1:n, k) = a(k + 1:n, k) / a(k, k)
            do i = k + 1, n
                a(k + 1:n, i) = a(k + 1:n, i) - a(k + 1:n, k) * a(k, i)
            end do
        end do
        if (present(pivot_ratio)) pivot_ratio = smallest / scale
    end subroutine lu_factor

    !> Solve A x = b with the factors from `lu_factor`; `b` is overwritten by x.
    !! Several right-hand sides may be given as columns of `b`.
    pure subroutine lu_solve(lu, pivots, b)
        real(wp), intent(in) :: lu(:, :)    !! factors from lu_factor (n x n)
        integer, intent(in) :: pivots(:)    !! interchanges from lu_factor
        real(wp), intent(inout) :: b(:, :)  !! n x nrhs: right-hand sides in, solutions out
        integer :: n, k, i
        real(wp) :: row(size(b, 2))

        n = size(lu, 1)
        do k = 1, n
            if (pivots(k) /= k) then
                row = b(k, :)
                b(k, :) = b(pivots(k), :)
                b(pivots(k), :) = row
            end if
        end do
        ! Forward substitution with unit L, column oriented.
        do k = 1, n
            do i = k + 1, n
                b(i, :) = b(i, :) - lu(i, k) * b(k, :)
            end do
        end do
        do k = n, 1, -1
            b(k, :) = b(k, :) / lu(k, k)
            do i = 1, k - 1
                b(i, :) = b(i, :) - lu(i, k) * b(k, :)
            end do
        end do
    end subroutine lu_solve

    !> Relative pivot threshold of the real64 factorisation: n * epsilon(1.0_dp).
    pure real(dp) function default_pivot_tolerance_dp(n)
        integer, intent(in) :: n !! matrix order
        default_pivot_tolerance_dp = max(n, 1) * epsilon(1.0_dp)
    end function default_pivot_tolerance_dp

    !> Argument check shared by the factorisations: -1 when A (rows x cols) is not square,
    !! -2 when the pivot array is shorter than n, else 0.
    pure integer function argument_info(rows, cols, pivot_count)
        integer, intent(in) :: rows, cols, pivot_count
        argument_info = 0
        if (cols /= rows) then
            argument_info = -1
        else if (pivot_count < rows) then
            argument_info = -2
        end if
    end function argument_info

    !> LU factorisation of a real64 matrix (own loops below order 32, LAPACK dgetrf above),
    !! with the same contract as `lu_factor`: `info` 0 success, -1 not square, -2 `pivots`
    !! too short, -4 `tolerance` not finite, k > 0 when the k-th pivot is at most
    !! `tolerance * max|A|` (default n * epsilon(1.0_dp)) or column k is the first with a
    !! NaN or infinite entry.
    subroutine lu_factor_dp(a, pivots, info, tolerance, pivot_ratio)
        real(dp), intent(inout), contiguous :: a(:, :) !! A (n x n) in, LAPACK factors out
        integer, intent(out) :: pivots(:)   !! row interchanges (LAPACK ipiv)
        integer, intent(out) :: info        !! 0, a negative argument index, or the singular step
        real(dp), intent(in), optional :: tolerance    !! relative pivot threshold
        real(dp), intent(out), optional :: pivot_ratio !! min |pivot| / max|A| (0 when singular)
        integer :: n, k, lapack_info
        real(dp) :: scale, threshold, smallest

        n = size(a, 1)
        if (present(pivot_ratio)) pivot_ratio = 0
        info = argument_info(n, size(a, 2), size(pivots))
        if (info /= 0) return
        if (present(tolerance)) then
            if (.not. ieee_is_finite(tolerance)) then
                info = -4
                return
            end if
        end if
        if (n == 0) then
            if (present(pivot_ratio)) pivot_ratio = 1
            return
        end if
        ! A NaN or infinite entry: singular at the first column holding one.
        do k = 1, n
            if (.not. all(ieee_is_finite(a(:, k)))) then
                info = k
                return
            end if
        end do
        scale = maxval(abs(a))
        if (present(tolerance)) then
            threshold = tolerance * scale
        else
            threshold = default_pivot_tolerance_dp(n) * scale
        end if
        if (n < small_lu_size) then
            call small_lu(a, pivots)
        else
            ! One thread at a time: a serial OpenBLAS (Debian's default) shares internal
            ! buffers between concurrent calls (seen as run-to-run differences in the OpenMP
            ! `tables`; none with the reference LAPACK or inside this critical section).
            !$omp critical (holosym_lapack)
            call dgetrf(n, n, a, size(a, 1), pivots, lapack_info)
            !$omp end critical (holosym_lapack)
        end if
        smallest = huge(1.0_dp)
        do k = 1, n
            ! Also catches scale == 0, LAPACK's exact zero pivots and NaN entries.
            if (.not. (abs(a(k, k)) > threshold)) then
                info = k
                return
            end if
            smallest = min(smallest, abs(a(k, k)))
        end do
        if (present(pivot_ratio)) pivot_ratio = smallest / scale
    end subroutine lu_factor_dp

    !> Right-looking LU with partial pivoting in LAPACK's conventions (unit lower L and U
    !! overwrite A, pivots(k) = the row swapped with row k), for small orders. Exact zero
    !! pivots are left for the caller's threshold test.
    pure subroutine small_lu(a, pivots)
        real(dp), intent(inout) :: a(:, :) !! A (n x n) in, factors out
        integer, intent(out) :: pivots(:)  !! row interchanges
        real(dp) :: swap(size(a, 2)), largest
        integer :: n, k, i, j, p
        n = size(a, 1)
        do k = 1, n
            p = k
            largest = abs(a(k, k))
            do i = k + 1, n
                if (abs(a(i, k)) > largest) then
                    p = i
                    largest = abs(a(i, k))
                end if
            end do
            pivots(k) = p
            if (p /= k) then
                swap = a(k, :)
                a(k, :) = a(p, :)
                a(p, :) = swap
            end if
            if (a(k, k) == 0) cycle
            a(k + 1:n, k) = a(k + 1:n, k) / a(k, k)
            do j = k + 1, n
                a(k + 1:n, j) = a(k + 1:n, j) - a(k + 1:n, k) * a(k, j)
            end do
        end do
    end subroutine small_lu

    !> Solve A x = b with the factors from `lu_factor_dp`; `b` (n x nrhs) is overwritten.
    subroutine lu_solve_dp(lu, pivots, b)
        real(dp), intent(in), contiguous :: lu(:, :)   !! factors from lu_factor_dp (n x n)
        integer, intent(in) :: pivots(:)    !! interchanges from lu_factor_dp
        real(dp), intent(inout), contiguous :: b(:, :) !! right-hand sides in, solutions out
        integer :: info, n
        n = size(lu, 1)
        if (n == 0) return
        if (size(b, 2) == 1 .and. n < blas_solve_size) then
            call substitute(lu, pivots, b(:, 1))
        else
            ! One thread at a time (see lu_factor_dp).
            !$omp critical (holosym_lapack)
            if (size(b, 2) == 1) then
                ! One right-hand side (Newton): the interchanges, then L and U by BLAS.
                call dlaswp(1, b, size(b, 1), 1, n, pivots, 1)
                call dtrsv("L", "N", "U", n, lu, n, b(:, 1), 1)
                call dtrsv("U", "N", "N", n, lu, n, b(:, 1), 1)
            else
                call dgetrs("N", n, size(b, 2), lu, n, pivots, b, size(b, 1), info)
            end if
            !$omp end critical (holosym_lapack)
        end if
    end subroutine lu_solve_dp

    !> One right-hand side with LAPACK factors: the interchanges in order, then forward
    !! (unit L) and back (U) substitution, column oriented.
    pure subroutine substitute(lu, pivots, x)
        real(dp), intent(in) :: lu(:, :)    !! factors from small_lu or dgetrf (n x n)
        integer, intent(in) :: pivots(:)    !! LAPACK ipiv
        real(dp), intent(inout) :: x(:)     !! right-hand side in, solution out
        integer :: n, k
        real(dp) :: swap
        n = size(lu, 1)
        do k = 1, n
            if (pivots(k) /= k) then
                swap = x(k)
                x(k) = x(pivots(k))
                x(pivots(k)) = swap
            end if
        end do
        do k = 1, n - 1
            x(k + 1:n) = x(k + 1:n) - lu(k + 1:n, k) * x(k)
        end do
        do k = n, 1, -1
            x(k) = x(k) / lu(k, k)
            x(1:k - 1) = x(1:k - 1) - lu(1:k - 1, k) * x(k)
        end do
    end subroutine substitute

end module holosym_linalg
