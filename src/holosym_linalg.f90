!> Dense linear algebra in working precision: LU factorisation with partial pivoting
!! and the matching solve, in the style of LAPACK's getrf/getrs.
!!
!! Reference LAPACK has no real128 routines, so these are written here. A pivot whose
!! magnitude is at most `tolerance * max|A|` (default `default_pivot_tolerance(n)` =
!! n * epsilon) marks the matrix as singular to working precision.
module holosym_linalg
    use holosym_kinds, only: wp
    implicit none
    private

    public :: lu_factor, lu_solve, default_pivot_tolerance

contains

    !> Relative pivot threshold used when none is given: n * epsilon(1.0_wp).
    pure real(wp) function default_pivot_tolerance(n)
        integer, intent(in) :: n !! matrix order
        default_pivot_tolerance = max(n, 1) * epsilon(1.0_wp)
    end function default_pivot_tolerance

    !> LU factorisation P A = L U with partial (row) pivoting, in place.
    !!
    !! `info`: 0 success; -1 `a` not square; -2 `pivots` too short; k > 0 when the k-th
    !! pivot is at most `tolerance * max|A|` (singular to working precision; the factors are
    !! then incomplete and must not be used). All-zero and empty matrices: see below.
    pure subroutine lu_factor(a, pivots, info, tolerance, pivot_ratio)
        real(wp), intent(inout) :: a(:, :)  !! on entry A (n x n); on exit L (unit, below) and U
        integer, intent(out) :: pivots(:)   !! row interchanges: row k was swapped with pivots(k)
        integer, intent(out) :: info        !! 0, a negative argument index, or the singular step
        real(wp), intent(in), optional :: tolerance   !! relative pivot threshold
        real(wp), intent(out), optional :: pivot_ratio !! min |pivot| / max|A| (0 when singular)
        integer :: n, k, p, i
        real(wp) :: scale, threshold, smallest, row(size(a, 2))

        n = size(a, 1)
        info = 0
        if (present(pivot_ratio)) pivot_ratio = 0
        if (size(a, 2) /= n) then
            info = -1
            return
        end if
        if (size(pivots) < n) then
            info = -2
            return
        end if
        if (n == 0) then
            if (present(pivot_ratio)) pivot_ratio = 1
            return
        end if
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

end module holosym_linalg
