!> category: internal module (use holosym)
!! real64 factors of a sparse Newton matrix: dense LU (LAPACK dgetrf through
!! `lu_factor_dp`) or banded LU (LAPACK dgbtrf/dgbtrs), chosen from the matrix's band.
!!
!! The matrix arrives in compressed sparse rows (a pattern fixed at `setup`, values per
!! factorisation). Rows are equilibrated by powers of two (exact) before the factorisation,
!! so that the pivot test does not depend on the units of the equations. The banded form
!! stores 2 kl + ku + 1 rows of length n (LAPACK band storage with room for the fill-in
!! of partial pivoting): memory and work grow linearly with n for a fixed band.
module holosym_factors
    use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
    use holosym_kinds, only: dp
    use holosym_linalg, only: lu_factor_dp, lu_solve_dp, default_pivot_tolerance_dp
    implicit none
    private

    public :: real64_factors_t

    interface
        !> LAPACK: LU factorisation of a real64 band matrix.
        subroutine dgbtrf(m, n, kl, ku, ab, ldab, ipiv, info)
            import :: dp
            integer, intent(in) :: m     !! rows
            integer, intent(in) :: n     !! columns
            integer, intent(in) :: kl    !! subdiagonals
            integer, intent(in) :: ku    !! superdiagonals
            integer, intent(in) :: ldab  !! leading dimension, >= 2 kl + ku + 1
            real(dp), intent(inout) :: ab(ldab, *) !! band storage in, factors out
            integer, intent(out) :: ipiv(*)       !! pivot indices
            integer, intent(out) :: info          !! 0, -i bad argument, i > 0 zero pivot
        end subroutine dgbtrf

        !> LAPACK: solve with the factors of dgbtrf.
        subroutine dgbtrs(trans, n, kl, ku, nrhs, ab, ldab, ipiv, b, ldb, info)
            import :: dp
            character(len=1), intent(in) :: trans !! 'N': A x = b
            integer, intent(in) :: n     !! order
            integer, intent(in) :: kl    !! subdiagonals
            integer, intent(in) :: ku    !! superdiagonals
            integer, intent(in) :: nrhs  !! right-hand sides
            integer, intent(in) :: ldab  !! leading dimension of ab
            real(dp), intent(in) :: ab(ldab, *)  !! factors from dgbtrf
            integer, intent(in) :: ipiv(*)       !! pivots from dgbtrf
            integer, intent(in) :: ldb   !! leading dimension of b
            real(dp), intent(inout) :: b(ldb, *) !! right-hand sides in, solutions out
            integer, intent(out) :: info         !! 0 or -i
        end subroutine dgbtrs
    end interface

    !> Factors of one n x n matrix with a fixed sparsity pattern.
    type :: real64_factors_t
        integer :: n = 0          !! order
        integer :: kl = 0         !! subdiagonals of the pattern
        integer :: ku = 0         !! superdiagonals of the pattern
        logical :: banded = .false. !! banded (dgbtrf) or dense (dgetrf) storage
        logical :: factored = .false. !! the factors are valid
        real(dp) :: pivot_ratio = 0   !! smallest |pivot| / max |entry| of the last factors
        real(dp), allocatable :: a(:, :)      !! dense matrix or band storage, then factors
        real(dp), allocatable :: row_scale(:) !! powers of two applied to the rows
        real(dp), allocatable :: rhs(:, :)    !! right-hand side workspace (n x 1)
        integer, allocatable :: pivots(:)     !! row interchanges
    contains
        !> Allocate for order n and bandwidths (kl, ku); banded when that is cheaper.
        procedure :: setup => factors_setup
        !> Load a matrix in compressed sparse rows and factor it.
        procedure :: factor => factors_factor
        !> Factor a dense matrix (set up dense).
        procedure :: factor_dense => factors_factor_dense
        !> Solve A x = b in place.
        procedure :: solve => factors_solve
    end type real64_factors_t

contains

    !> Choose the storage for order n and bandwidths (kl, ku) and allocate it. Banded
    !! storage is used when its factorisation, about n kl (kl + ku) flops, is at most a
    !! quarter of the dense n^3 / 3.
    subroutine factors_setup(self, n, kl, ku)
        class(real64_factors_t), intent(inout) :: self
        integer, intent(in) :: n  !! order
        integer, intent(in) :: kl !! subdiagonals (0 <= kl < n)
        integer, intent(in) :: ku !! superdiagonals (0 <= ku < n)
        self%n = n
        self%kl = kl
        self%ku = ku
        self%banded = 12 * real(kl, dp) * real(kl + ku + 1, dp) <= real(n, dp)**2
        if (allocated(self%a)) deallocate (self%a, self%row_scale, self%rhs, self%pivots)
        if (self%banded) then
            allocate (self%a(2 * kl + ku + 1, n))
        else
            allocate (self%a(n, n))
        end if
        allocate (self%row_scale(n), self%rhs(n, 1), self%pivots(n))
        self%factored = .false.
    end subroutine factors_setup

    !> Load the matrix (compressed sparse rows: row r holds the entries
    !! row_start(r) .. row_start(r+1)-1 of `columns` and `values`), equilibrate its rows and
    !! factor it. `info` is 0, or k > 0 when the k-th pivot is at most `pivot_tolerance`
    !! (absent or <= 0: n epsilon(1.0_dp)) times the largest entry (singular to that
    !! relative precision).
    subroutine factors_factor(self, row_start, columns, values, info, pivot_tolerance)
        class(real64_factors_t), intent(inout) :: self
        integer, intent(in) :: row_start(:)  !! n + 1 row offsets
        integer, intent(in) :: columns(:)    !! column of each entry
        real(dp), intent(in) :: values(:)    !! value of each entry
        integer, intent(out) :: info         !! 0 or the singular pivot
        real(dp), intent(in), optional :: pivot_tolerance !! relative pivot threshold
        real(dp) :: row_max, scale, threshold, smallest, relative
        integer :: r, e, k, lapack_info, diag_row

        self%factored = .false.
        self%a = 0
        diag_row = self%kl + self%ku + 1
        scale = 0
        do r = 1, self%n
            row_max = 0
            do e = row_start(r), row_start(r + 1) - 1
                row_max = max(row_max, abs(values(e)))
            end do
            self%row_scale(r) = 1
            if (ieee_is_finite(row_max)) then
                if (row_max > 0) self%row_scale(r) = set_exponent(1.0_dp, 1 - exponent(row_max))
            end if
            do e = row_start(r), row_start(r + 1) - 1
                if (self%banded) then
                    self%a(diag_row + r - columns(e), columns(e)) = values(e) * self%row_scale(r)
                else
                    self%a(r, columns(e)) = values(e) * self%row_scale(r)
                end if
            end do
            scale = max(scale, row_max * self%row_scale(r))
        end do
        relative = default_pivot_tolerance_dp(self%n)
        if (present(pivot_tolerance)) then
            if (pivot_tolerance > 0) relative = pivot_tolerance
        end if
        if (.not. self%banded) then
            call lu_factor_dp(self%a, self%pivots, info, tolerance=relative, &
                              pivot_ratio=self%pivot_ratio)
            self%factored = info == 0
            return
        end if
        ! One thread at a time: a serial OpenBLAS is not safe for concurrent calls.
        !$omp critical (holosym_lapack)
        call dgbtrf(self%n, self%n, self%kl, self%ku, self%a, size(self%a, 1), self%pivots, &
                    lapack_info)
        !$omp end critical (holosym_lapack)
        threshold = relative * scale
        smallest = huge(1.0_dp)
        info = 0
        do k = 1, self%n
            ! Also catches scale == 0, exact zero pivots and NaN entries.
            if (.not. (abs(self%a(diag_row, k)) > threshold)) then
                info = k
                self%pivot_ratio = 0
                return
            end if
            smallest = min(smallest, abs(self%a(diag_row, k)))
        end do
        self%pivot_ratio = smallest / scale
        self%factored = .true.
    end subroutine factors_factor

    !> Factor the dense n x n matrix `a` (the factors set up dense): `factor` with every
    !! entry in the pattern. `info` as for `factor`.
    subroutine factors_factor_dense(self, a, info, pivot_tolerance)
        class(real64_factors_t), intent(inout) :: self
        real(dp), intent(in) :: a(:, :)      !! the matrix (n x n)
        integer, intent(out) :: info         !! 0 or the singular pivot
        real(dp), intent(in), optional :: pivot_tolerance !! relative pivot threshold
        integer :: r, k, n
        n = size(a, 1)
        call self%factor([(1 + (r - 1) * n, r = 1, n + 1)], [((k, k = 1, n), r = 1, n)], &
                         reshape(transpose(a), [n * n]), info, pivot_tolerance)
    end subroutine factors_factor_dense

    !> Solve A x = b with the factors; b is overwritten by x.
    subroutine factors_solve(self, b)
        class(real64_factors_t), intent(inout) :: self
        real(dp), intent(inout) :: b(:) !! right-hand side in, solution out (n)
        integer :: info
        self%rhs(:, 1) = b * self%row_scale
        if (self%banded) then
            !$omp critical (holosym_lapack)
            call dgbtrs("N", self%n, self%kl, self%ku, 1, self%a, size(self%a, 1), &
                        self%pivots, self%rhs, self%n, info)
            !$omp end critical (holosym_lapack)
        else
            call lu_solve_dp(self%a, self%pivots, self%rhs)
        end if
        b = self%rhs(:, 1)
    end subroutine factors_solve

end module holosym_factors
