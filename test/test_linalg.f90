!> Tests of the linalg part of holosym: LU factorisation with partial pivoting and solve.
module test_linalg
    use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan, ieee_positive_inf
    use holosym_kinds, only: wp, dp
    use holosym_status_codes, only: int_str, real_str
    use holosym_linalg, only: lu_factor, lu_solve, default_pivot_tolerance, lu_factor_dp, &
        lu_solve_dp
    use holosym_testing, only: test_case_t, new_test, test_error_t, check, check_close
    implicit none
    private
    public :: linalg_tests

    real(wp), parameter :: eps = epsilon(1.0_wp)
    !> Largest order of the random systems.
    integer, parameter :: max_order = 40
    !> Bound on the normwise relative residual ||Ax - b|| / (||A|| ||x||) (about 1e-30).
    real(wp), parameter :: residual_tolerance = 4096 * eps
    !> Largest order of the real64 random systems: beyond both of `lu_factor_dp`'s
    !! switches (own loops -> dgetrf at 32, substitution loops -> dtrsv at 64).
    integer, parameter :: max_order_dp = 80
    !> Orders of the concurrency test: own loops and dgetrf, then dtrsv (one right-hand side)
    !! and dgetrs (several) above the substitution loops' range.
    integer, parameter :: concurrent_orders(3) = [20, 72, 96]
    !> Right-hand sides of the concurrency test, solved one by one and all at once.
    integer, parameter :: concurrent_rhs = 4
    !> Factor-and-solve calls of the concurrency test, spread over two threads.
    integer, parameter :: concurrent_calls = 1000

contains

    !> The tests of this suite.
    function linalg_tests() result(tests)
        type(test_case_t), allocatable :: tests(:)
        tests = [ &
            ! First: it must make the process's first LAPACK/BLAS calls (see concurrent_dp).
            new_test("real64_concurrent_calls_match_serial", concurrent_dp), &
            new_test("random_systems_sizes_1_to_40", random_systems), &
            new_test("multiple_right_hand_sides", multiple_rhs), &
            new_test("identity_solves_exactly", identity_exact), &
            new_test("needs_pivoting_zero_diagonal", needs_pivoting), &
            new_test("small_integer_system_exact", integer_system), &
            new_test("reconstructs_pa_from_factors", reconstruct_pa), &
            new_test("singular_zero_matrix", singular_zero), &
            new_test("singular_zero_column", singular_zero_column), &
            new_test("singular_repeated_row", singular_repeated_row), &
            new_test("singular_rank_deficient_product", singular_product), &
            new_test("singular_classic_3x3", singular_classic), &
            new_test("nan_and_inf_entries_reported", nonfinite_entries), &
            new_test("tolerance_argument_respected", tolerance_argument), &
            new_test("pivot_ratio_in_0_1", pivot_ratio_range), &
            new_test("non_square_negative_info", non_square), &
            new_test("short_pivots_negative_info", short_pivots), &
            new_test("empty_matrix", empty_matrix), &
            new_test("default_pivot_tolerance_value", default_tolerance), &
            new_test("real64_random_systems_sizes_1_to_80", random_systems_dp), &
            new_test("real64_singular_and_argument_errors", singular_dp) &
            ]
    end function linalg_tests

    ! ------------------------------------------------------------------ helpers

    !> Seed the intrinsic generator with a fixed seed (reproducible tests).
    subroutine fixed_seed(offset)
        integer, intent(in) :: offset !! distinguishes the tests' streams
        integer :: n, i
        integer, allocatable :: seed(:)
        call random_seed(size=n)
        allocate (seed(n))
        seed = [(104729 * i + 7919 * offset + 12345, i = 1, n)]
        call random_seed(put=seed)
    end subroutine fixed_seed

    !> A matrix with entries uniform in [-1, 1].
    function random_matrix(rows, cols) result(a)
        integer, intent(in) :: rows !! rows
        integer, intent(in) :: cols !! columns
        real(wp) :: a(rows, cols)
        call random_number(a)
        a = 2 * a - 1
    end function random_matrix

    !> Infinity norm of a matrix.
    pure real(wp) function norm_inf(a)
        real(wp), intent(in) :: a(:, :) !! matrix
        norm_inf = maxval(sum(abs(a), dim=2))
    end function norm_inf

    !> Normwise relative residual ||A x - b||_inf / (||A||_inf ||x||_inf) of one column.
    pure real(wp) function relative_residual(a, x, b)
        real(wp), intent(in) :: a(:, :) !! matrix
        real(wp), intent(in) :: x(:)    !! solution
        real(wp), intent(in) :: b(:)    !! right-hand side
        relative_residual = maxval(abs(matmul(a, x) - b)) / (norm_inf(a) * maxval(abs(x)))
    end function relative_residual

    ! ------------------------------------------------------------------ solves

    !> Random A and x (orders 1..40), b = A x: the residual is at round-off level and the
    !! factorisation succeeds with a pivot ratio in (0, 1].
    subroutine random_systems(error)
        type(test_error_t), allocatable, intent(out) :: error
        integer :: n, info
        real(wp), allocatable :: a(:, :), lu(:, :), x(:, :), b(:, :)
        integer, allocatable :: pivots(:)
        real(wp) :: ratio, residual
        call fixed_seed(1)
        do n = 1, max_order
            a = random_matrix(n, n)
            x = random_matrix(n, 1)
            b = matmul(a, x)
            lu = a
            allocate (pivots(n))
            call lu_factor(lu, pivots, info, pivot_ratio=ratio)
            call check(error, info == 0, "n = " // int_str(n) // ": info = " // int_str(info))
            call check(error, ratio > 0 .and. ratio <= 1, "n = " // int_str(n) // &
                ": pivot_ratio = " // real_str(ratio))
            if (allocated(error)) return
            x = b
            call lu_solve(lu, pivots, x)
            residual = relative_residual(a, x(:, 1), b(:, 1))
            call check(error, residual <= residual_tolerance, "n = " // int_str(n) // &
                ": relative residual " // real_str(residual))
            if (allocated(error)) return
            deallocate (pivots)
        end do
    end subroutine random_systems

    !> The real64 LAPACK path on random systems of orders 1..80, one right-hand side and
    !! three: relative residuals at real64 round-off, the same solution either way.
    subroutine random_systems_dp(error)
        type(test_error_t), allocatable, intent(out) :: error
        integer, parameter :: nrhs = 3
        integer :: n, info
        real(wp), allocatable :: a(:, :), x(:, :)
        real(dp), allocatable :: lu(:, :), b(:, :), rhs(:, :), single(:, :)
        integer, allocatable :: pivots(:)
        real(dp) :: ratio
        real(wp) :: residual
        real(wp), parameter :: tolerance_dp = 4096 * real(epsilon(1.0_dp), wp)
        call fixed_seed(21)
        do n = 1, max_order_dp
            a = real(real(random_matrix(n, n), dp), wp)   ! exactly representable in real64
            x = random_matrix(n, nrhs)
            b = real(matmul(a, x), dp)
            rhs = b
            lu = real(a, dp)
            allocate (pivots(n))
            call lu_factor_dp(lu, pivots, info, pivot_ratio=ratio)
            call check(error, info == 0 .and. ratio > 0 .and. ratio <= 1, "n = " // &
                int_str(n) // ": info = " // int_str(info) // ", pivot ratio " // &
                real_str(real(ratio, wp)))
            if (allocated(error)) return
            single = b(:, 1:1)
            call lu_solve_dp(lu, pivots, single)
            call lu_solve_dp(lu, pivots, b)
            residual = relative_residual(a, real(single(:, 1), wp), real(rhs(:, 1), wp))
            call check(error, residual <= tolerance_dp, "n = " // int_str(n) // &
                ": relative residual " // real_str(residual))
            call check(error, maxval(abs(single(:, 1) - b(:, 1))) <= &
                tolerance_dp * maxval(abs(b(:, 1))) * n, "n = " // int_str(n) // &
                ": one right-hand side and three differ")
            if (allocated(error)) return
            deallocate (pivots)
        end do
    end subroutine random_systems_dp

    !> Factorisations and solves run concurrently from two OpenMP threads (as the `tables`
    !! and `extremes` commands do) give the same bits as serial ones. A serial OpenBLAS
    !! (Debian's default) is not safe for concurrent calls: without holosym's critical
    !! section around the LAPACK/BLAS calls this test failed in 12 of 12 runs (1-8 of the
    !! 1000 calls gave wrong solutions, in dtrsv/dgetrs); with it, none in 25 runs. It runs
    !! first among the LAPACK users, so that its threads also make the process's first calls.
    subroutine concurrent_dp(error)
        type(test_error_t), allocatable, intent(out) :: error
        integer, parameter :: systems = size(concurrent_orders)
        type :: system_t
            real(dp), allocatable :: a(:, :), b(:, :), x(:, :)
        end type system_t
        type(system_t) :: sys(systems)
        type(system_t), allocatable :: results(:)
        integer :: k, s, n, mismatches
        call fixed_seed(23)
        do s = 1, systems
            n = concurrent_orders(s)
            sys(s)%a = real(random_matrix(n, n), dp)
            sys(s)%b = real(random_matrix(n, concurrent_rhs), dp)
        end do
        allocate (results(concurrent_calls))
        !$omp parallel do num_threads(2) schedule(static, 1) private(s)
        do k = 1, concurrent_calls
            s = 1 + mod(k, systems)
            results(k)%x = factor_and_solve(sys(s)%a, sys(s)%b)
        end do
        !$omp end parallel do
        do s = 1, systems
            sys(s)%x = factor_and_solve(sys(s)%a, sys(s)%b)
        end do
        mismatches = 0
        do k = 1, concurrent_calls
            s = 1 + mod(k, systems)
            if (any(results(k)%x /= sys(s)%x)) mismatches = mismatches + 1
        end do
        call check(error, mismatches == 0, int_str(mismatches) // " of " // &
            int_str(concurrent_calls) // " concurrent factor-and-solve calls differ from " // &
            "the serial result")
    contains
        !> Solutions of a x = b by lu_factor_dp and lu_solve_dp, the columns of b solved one
        !! by one, then all at once (NaN when singular).
        function factor_and_solve(a, b) result(x)
            real(dp), intent(in) :: a(:, :), b(:, :)
            real(dp) :: x(size(b, 1), 2 * size(b, 2))
            real(dp) :: lu(size(a, 1), size(a, 2))
            integer :: pivots(size(a, 1)), info, j, nrhs
            nrhs = size(b, 2)
            lu = a
            x(:, 1:nrhs) = b
            x(:, nrhs + 1:) = b
            call lu_factor_dp(lu, pivots, info)
            if (info /= 0) then
                x = ieee_value(1.0_dp, ieee_quiet_nan)
                return
            end if
            do j = 1, nrhs
                call lu_solve_dp(lu, pivots, x(:, j:j))
            end do
            call lu_solve_dp(lu, pivots, x(:, nrhs + 1:))
        end function factor_and_solve
    end subroutine concurrent_dp

    !> The real64 factorisation reports singular matrices (info > 0), NaN entries, and
    !! bad shapes (-1, -2), as `lu_factor` does.
    subroutine singular_dp(error)
        type(test_error_t), allocatable, intent(out) :: error
        integer, parameter :: n = 40
        real(dp) :: a(n, n), not_square(n, n - 1)
        integer :: pivots(n), info
        call fixed_seed(22)
        a = real(random_matrix(n, n), dp)
        a(n, :) = a(1, :)
        call lu_factor_dp(a, pivots, info)
        call check(error, info > 0, "repeated row: info = " // int_str(info))
        a = real(random_matrix(n, n), dp)
        a(7, 3) = ieee_value(a(7, 3), ieee_quiet_nan)
        call lu_factor_dp(a, pivots, info)
        call check(error, info > 0, "NaN entry: info = " // int_str(info))
        not_square = 1
        call lu_factor_dp(not_square, pivots, info)
        call check(error, info == -1, "not square: info = " // int_str(info))
        a = real(random_matrix(n, n), dp)
        call lu_factor_dp(a, pivots(1:n - 1), info)
        call check(error, info == -2, "short pivots: info = " // int_str(info))
    end subroutine singular_dp

    !> Several right-hand sides at once give, column by column, bit for bit the same
    !! solutions as single solves, each with a round-off residual.
    subroutine multiple_rhs(error)
        type(test_error_t), allocatable, intent(out) :: error
        integer, parameter :: n = 17, nrhs = 5
        real(wp) :: a(n, n), lu(n, n), b(n, nrhs), x(n, nrhs), single(n, 1)
        integer :: pivots(n), info, j
        call fixed_seed(2)
        a = random_matrix(n, n)
        b = random_matrix(n, nrhs)
        lu = a
        call lu_factor(lu, pivots, info)
        call check(error, info == 0, "info = " // int_str(info))
        if (allocated(error)) return
        x = b
        call lu_solve(lu, pivots, x)
        do j = 1, nrhs
            single(:, 1) = b(:, j)
            call lu_solve(lu, pivots, single)
            call check(error, all(single(:, 1) == x(:, j)), "column " // int_str(j) // &
                " differs from its single solve")
            call check(error, relative_residual(a, x(:, j), b(:, j)) <= residual_tolerance, &
                "column " // int_str(j) // ": residual " // &
                real_str(relative_residual(a, x(:, j), b(:, j))))
        end do
    end subroutine multiple_rhs

    !> The identity: no interchanges, pivot ratio 1, x = b exactly.
    subroutine identity_exact(error)
        type(test_error_t), allocatable, intent(out) :: error
        integer, parameter :: n = 6
        real(wp) :: a(n, n), b(n, 2), x(n, 2), ratio
        integer :: pivots(n), info, i
        a = 0
        do i = 1, n
            a(i, i) = 1
        end do
        call fixed_seed(3)
        b = random_matrix(n, 2)
        call lu_factor(a, pivots, info, pivot_ratio=ratio)
        call check(error, info == 0, "info = " // int_str(info))
        call check(error, all(pivots == [(i, i = 1, n)]), "identity needed interchanges")
        call check(error, ratio == 1.0_wp, "pivot ratio of I is " // real_str(ratio))
        x = b
        call lu_solve(a, pivots, x)
        call check(error, all(x == b), "I x = b not solved exactly")
    end subroutine identity_exact

    !> A matrix with zeros on the diagonal (fails without pivoting) is solved correctly.
    subroutine needs_pivoting(error)
        type(test_error_t), allocatable, intent(out) :: error
        real(wp) :: a(3, 3), lu(3, 3), x(3, 1), exact(3)
        integer :: pivots(3), info, i
        a = reshape([0.0_wp, 1.0_wp, 3.0_wp, &
                     2.0_wp, 0.0_wp, 1.0_wp, &
                     1.0_wp, 4.0_wp, 0.0_wp], [3, 3])
        exact = [1.0_wp, -2.0_wp, 0.5_wp]
        lu = a
        call lu_factor(lu, pivots, info)
        call check(error, info == 0, "info = " // int_str(info))
        call check(error, any(pivots /= [1, 2, 3]), "no row interchange recorded")
        if (allocated(error)) return
        x(:, 1) = matmul(a, exact)
        call lu_solve(lu, pivots, x)
        do i = 1, 3
            call check_close(error, x(i, 1), exact(i), 8 * eps, 0.0_wp, "x(" // int_str(i) // ")")
        end do
        ! 2 x 2 anti-diagonal: the permutation alone solves it.
        lu(1:2, 1:2) = reshape([0.0_wp, 1.0_wp, 1.0_wp, 0.0_wp], [2, 2])
        call lu_factor(lu(1:2, 1:2), pivots(1:2), info)
        x(1:2, 1) = [3.0_wp, 7.0_wp]
        call lu_solve(lu(1:2, 1:2), pivots(1:2), x(1:2, :))
        call check(error, info == 0 .and. x(1, 1) == 7.0_wp .and. x(2, 1) == 3.0_wp, &
            "anti-diagonal system not solved exactly")
    end subroutine needs_pivoting

    !> A well-conditioned integer system with an integer solution is solved to a few ulps.
    subroutine integer_system(error)
        type(test_error_t), allocatable, intent(out) :: error
        real(wp) :: a(4, 4), lu(4, 4), x(4, 1), exact(4)
        integer :: pivots(4), info, i
        a = reshape([4.0_wp, -2.0_wp, 1.0_wp, 0.0_wp, &
                     3.0_wp, 6.0_wp, -4.0_wp, 2.0_wp, &
                     2.0_wp, 1.0_wp, 8.0_wp, -5.0_wp, &
                     1.0_wp, 3.0_wp, -2.0_wp, 7.0_wp], [4, 4])
        exact = [1.0_wp, -1.0_wp, 2.0_wp, 3.0_wp]
        lu = a
        call lu_factor(lu, pivots, info)
        call check(error, info == 0, "info = " // int_str(info))
        x(:, 1) = matmul(a, exact)
        call lu_solve(lu, pivots, x)
        do i = 1, 4
            call check_close(error, x(i, 1), exact(i), 16 * eps, 16 * eps, &
                "x(" // int_str(i) // ")")
        end do
    end subroutine integer_system

    !> L U equals P A (the interchanges applied to A) to round-off; |L| <= 1.
    subroutine reconstruct_pa(error)
        type(test_error_t), allocatable, intent(out) :: error
        integer, parameter :: n = 12
        real(wp) :: a(n, n), lu(n, n), l(n, n), u(n, n), pa(n, n), row(n)
        integer :: pivots(n), info, i, k
        call fixed_seed(4)
        a = random_matrix(n, n)
        lu = a
        call lu_factor(lu, pivots, info)
        call check(error, info == 0, "info = " // int_str(info))
        if (allocated(error)) return
        l = 0
        u = 0
        do i = 1, n
            l(i, i) = 1
            l(i, 1:i - 1) = lu(i, 1:i - 1)
            u(i, i:n) = lu(i, i:n)
        end do
        pa = a
        do k = 1, n
            row = pa(k, :)
            pa(k, :) = pa(pivots(k), :)
            pa(pivots(k), :) = row
        end do
        call check(error, maxval(abs(l)) <= 1, "partial pivoting must give |L| <= 1")
        call check(error, maxval(abs(matmul(l, u) - pa)) <= residual_tolerance * norm_inf(a), &
            "L U differs from P A by " // real_str(maxval(abs(matmul(l, u) - pa))))
    end subroutine reconstruct_pa

    ! ------------------------------------------------------------------ singular matrices

    !> The zero matrix fails at the first pivot; pivot_ratio is 0.
    subroutine singular_zero(error)
        type(test_error_t), allocatable, intent(out) :: error
        real(wp) :: a(4, 4), ratio
        integer :: pivots(4), info
        a = 0
        call lu_factor(a, pivots, info, pivot_ratio=ratio)
        call check(error, info == 1, "zero matrix: info = " // int_str(info) // ", expected 1")
        call check(error, ratio == 0, "zero matrix: pivot_ratio = " // real_str(ratio))
    end subroutine singular_zero

    !> A zero column k is reported at step k exactly.
    subroutine singular_zero_column(error)
        type(test_error_t), allocatable, intent(out) :: error
        real(wp) :: a(5, 5)
        integer :: pivots(5), info
        call fixed_seed(5)
        a = random_matrix(5, 5)
        a(:, 3) = 0
        call lu_factor(a, pivots, info)
        call check(error, info == 3, "zero column 3: info = " // int_str(info))
    end subroutine singular_zero_column

    !> Two equal rows make a zero pivot (info > 0), for several orders.
    subroutine singular_repeated_row(error)
        type(test_error_t), allocatable, intent(out) :: error
        integer :: n, info
        real(wp), allocatable :: a(:, :)
        integer, allocatable :: pivots(:)
        call fixed_seed(6)
        do n = 2, 12
            a = random_matrix(n, n)
            a(n, :) = a(1, :)
            allocate (pivots(n))
            call lu_factor(a, pivots, info)
            call check(error, info > 0, "n = " // int_str(n) // ", repeated row: info = " // &
                int_str(info))
            if (allocated(error)) return
            deallocate (pivots)
        end do
    end subroutine singular_repeated_row

    !> A = U V^T with U, V of rank r < n (small integer entries, so A is exact) is reported
    !! singular (info > 0), for n = 3..10 and every r < n.
    subroutine singular_product(error)
        type(test_error_t), allocatable, intent(out) :: error
        integer :: n, r, info
        real(wp), allocatable :: u(:, :), v(:, :), a(:, :)
        integer, allocatable :: pivots(:)
        call fixed_seed(7)
        do n = 3, 10
            do r = 1, n - 1
                u = anint(9 * random_matrix(n, r))
                v = anint(9 * random_matrix(n, r))
                a = matmul(u, transpose(v))
                if (maxval(abs(a)) == 0) cycle
                allocate (pivots(n))
                call lu_factor(a, pivots, info)
                ! After r pivots the Schur complement is round-off only, so info is about
                ! r+1; its round-off may pass n*eps once or twice more, never all the way.
                call check(error, info >= 1, "n = " // int_str(n) // ", rank " // int_str(r) &
                    // ": info = " // int_str(info))
                if (allocated(error)) return
                deallocate (pivots)
            end do
        end do
    end subroutine singular_product

    !> The classic [[1,2,3],[4,5,6],[7,8,9]] is singular to working precision.
    subroutine singular_classic(error)
        type(test_error_t), allocatable, intent(out) :: error
        real(wp) :: a(3, 3)
        integer :: pivots(3), info
        a = reshape([1.0_wp, 4.0_wp, 7.0_wp, 2.0_wp, 5.0_wp, 8.0_wp, 3.0_wp, 6.0_wp, 9.0_wp], &
            [3, 3])
        call lu_factor(a, pivots, info)
        call check(error, info == 3, "info = " // int_str(info) // ", expected 3")
    end subroutine singular_classic

    !> A NaN or an Inf entry is reported as a failed pivot (info > 0), never as success.
    subroutine nonfinite_entries(error)
        type(test_error_t), allocatable, intent(out) :: error
        integer, parameter :: n = 4
        real(wp) :: a(n, n), base(n, n)
        integer :: pivots(n), info, i, j
        call fixed_seed(8)
        base = random_matrix(n, n)
        do j = 1, n
            do i = 1, n
                a = base
                a(i, j) = ieee_value(1.0_wp, ieee_quiet_nan)
                call lu_factor(a, pivots, info)
                call check(error, info > 0, "NaN at (" // int_str(i) // ", " // int_str(j) // &
                    "): info = " // int_str(info))
                a = base
                a(i, j) = ieee_value(1.0_wp, ieee_positive_inf)
                call lu_factor(a, pivots, info)
                call check(error, info > 0, "Inf at (" // int_str(i) // ", " // int_str(j) // &
                    "): info = " // int_str(info))
                if (allocated(error)) return
            end do
        end do
    end subroutine nonfinite_entries

    !> diag(1, 1e-20): fine with the default threshold, singular with tolerance 1e-10.
    subroutine tolerance_argument(error)
        type(test_error_t), allocatable, intent(out) :: error
        !> A pivot far above the default threshold (2 eps) yet far below the explicit
        !! tolerance 1e-10: 1e-20 in real128, 1e4 eps (2.2e-12) in real64.
        real(wp), parameter :: small = max(1.0e-20_wp, 1.0e4_wp * eps)
        real(wp) :: a(2, 2), ratio
        integer :: pivots(2), info
        a = reshape([1.0_wp, 0.0_wp, 0.0_wp, small], [2, 2])
        call lu_factor(a, pivots, info, pivot_ratio=ratio)
        call check(error, info == 0, "default threshold: info = " // int_str(info))
        call check_close(error, ratio, small, eps, 0.0_wp, "pivot ratio of diag(1, small)")
        a = reshape([1.0_wp, 0.0_wp, 0.0_wp, small], [2, 2])
        call lu_factor(a, pivots, info, tolerance=1.0e-10_wp, pivot_ratio=ratio)
        call check(error, info == 2, "tolerance 1e-10: info = " // int_str(info))
        call check(error, ratio == 0, "pivot_ratio must be 0 when singular")
        ! The threshold is relative to max|A|: scaling A does not change the verdict.
        a = reshape([1.0e30_wp, 0.0_wp, 0.0_wp, 1.0e10_wp], [2, 2])
        call lu_factor(a, pivots, info, tolerance=1.0e-10_wp)
        call check(error, info == 2, "scaled, tolerance 1e-10: info = " // int_str(info))
        a = reshape([1.0e30_wp, 0.0_wp, 0.0_wp, 1.0e25_wp], [2, 2])
        call lu_factor(a, pivots, info, tolerance=1.0e-10_wp)
        call check(error, info == 0, "scaled, ratio 1e-5: info = " // int_str(info))
    end subroutine tolerance_argument

    !> The pivot ratio lies in (0, 1] and equals min|u_kk| / max|A| on a triangular example.
    subroutine pivot_ratio_range(error)
        type(test_error_t), allocatable, intent(out) :: error
        real(wp) :: a(3, 3), ratio
        integer :: pivots(3), info, n
        real(wp), allocatable :: b(:, :)
        integer, allocatable :: pv(:)
        a = reshape([4.0_wp, 0.0_wp, 0.0_wp, 1.0_wp, 2.0_wp, 0.0_wp, 1.0_wp, 1.0_wp, 0.5_wp], &
            [3, 3])
        call lu_factor(a, pivots, info, pivot_ratio=ratio)
        call check(error, info == 0, "info = " // int_str(info))
        call check(error, ratio == 0.125_wp, "upper triangular: ratio " // real_str(ratio) // &
            ", expected 0.125")
        call fixed_seed(9)
        do n = 1, 20
            b = random_matrix(n, n)
            allocate (pv(n))
            call lu_factor(b, pv, info, pivot_ratio=ratio)
            call check(error, info /= 0 .or. (ratio > 0 .and. ratio <= 1), "n = " // &
                int_str(n) // ": pivot ratio " // real_str(ratio) // " not in (0, 1]")
            if (allocated(error)) return
            deallocate (pv)
        end do
    end subroutine pivot_ratio_range

    ! ------------------------------------------------------------------ invalid arguments

    !> A non-square matrix gives info = -1.
    subroutine non_square(error)
        type(test_error_t), allocatable, intent(out) :: error
        real(wp) :: a(3, 4), b(4, 3)
        integer :: pivots(4), info
        a = 1
        b = 1
        call lu_factor(a, pivots, info)
        call check(error, info == -1, "3 x 4: info = " // int_str(info))
        call lu_factor(b, pivots, info)
        call check(error, info == -1, "4 x 3: info = " // int_str(info))
    end subroutine non_square

    !> Fewer pivots than rows gives info = -2 and leaves A untouched.
    subroutine short_pivots(error)
        type(test_error_t), allocatable, intent(out) :: error
        real(wp) :: a(3, 3), saved(3, 3)
        integer :: pivots(2), info
        call fixed_seed(10)
        a = random_matrix(3, 3)
        saved = a
        call lu_factor(a, pivots, info)
        call check(error, info == -2, "2 pivots for 3 x 3: info = " // int_str(info))
        call check(error, all(a == saved), "a was modified by a rejected call")
    end subroutine short_pivots

    !> A 0 x 0 matrix is a valid, trivial factorisation (info 0, pivot ratio 1).
    subroutine empty_matrix(error)
        type(test_error_t), allocatable, intent(out) :: error
        real(wp) :: a(0, 0), b(0, 1), ratio
        integer :: pivots(0), info
        call lu_factor(a, pivots, info, pivot_ratio=ratio)
        call check(error, info == 0, "0 x 0: info = " // int_str(info))
        call check(error, ratio == 1, "0 x 0: pivot_ratio = " // real_str(ratio))
        call lu_solve(a, pivots, b)
        call check(error, size(b) == 0, "0 x 0 solve")
    end subroutine empty_matrix

    !> default_pivot_tolerance(n) = max(n, 1) epsilon.
    subroutine default_tolerance(error)
        type(test_error_t), allocatable, intent(out) :: error
        call check(error, default_pivot_tolerance(10) == 10 * eps, "n = 10")
        call check(error, default_pivot_tolerance(0) == eps, "n = 0")
    end subroutine default_tolerance

end module test_linalg
