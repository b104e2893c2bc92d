!> category: internal module (use holosym)
!! The constraint manifold {phi(q) = 0, Phi(q) H_p(q, p) = 0}: residuals of a state, scaled
!! so that a tolerance tied to epsilon means "at round-off level", and the rank test of Phi.
module holosym_manifold
    use, intrinsic :: iso_fortran_env, only: int64
    use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan
    use holosym_kinds, only: wp
    use holosym_problem, only: constrained_hamiltonian
    use holosym_linalg, only: lu_factor
    use holosym_status_codes, only: int_str, real_str, is_finite
    implicit none
    private

    public :: manifold_residuals, full_rank_constraints, sparse_manifold_residuals, &
        sparse_full_rank_constraints, gram_band, band_cholesky, band_cholesky_solve, &
        sparse_scaled_position

    !> Default tolerance on the scaled residuals: 2**10 epsilon, room for the round-off of
    !! evaluating phi and Phi H_p with a few hundred operations.
    real(wp), parameter, public :: manifold_tolerance_default = 1024 * epsilon(1.0_wp)
    !> Entries of Phi beyond which `manifold_residuals` takes the system's declared sparsity
    !! (when it has one) instead of forming the m x n matrix: below, forming Phi costs less
    !! than the pattern's bookkeeping; above, the pattern keeps the cost linear in the size
    !! of a chain-like system (the command line evaluates these residuals after every step).
    integer(int64), parameter :: dense_entries_limit = 1024

contains

    !> Residuals of a state: `position = max|phi(q)|`, `velocity = max|Phi(q) H_p(q,p)|`,
    !! and the same divided by their round-off scales, 1 + |q| |Phi_l| for phi_l and
    !! 1 + sum_i |Phi_li| |H_p,i| for the hidden constraint l. All are NaN when the system
    !! returns a NaN or infinite value, or when Phi is too large to form (m n entries
    !! beyond the default integer) and the system declares no sparsity. A system with more
    !! than `dense_entries_limit` entries of Phi and a declared sparsity is evaluated on
    !! its pattern (`sparse_manifold_residuals`): a chain of 10^5 links needs no
    !! 10^5 x 2 10^5 matrix, and a chain of 64 no 64 x 128 one.
    subroutine manifold_residuals(sys, q, p, position, velocity, scaled_position, &
                                  scaled_velocity, velocity_field)
        class(constrained_hamiltonian), intent(in) :: sys !! the system
        real(wp), intent(in) :: q(:)  !! coordinates (n)
        real(wp), intent(in) :: p(:)  !! momenta (n)
        real(wp), intent(out) :: position  !! max |phi_l(q)|
        real(wp), intent(out) :: velocity  !! max |(Phi(q) H_p(q,p))_l|
        real(wp), intent(out), optional :: scaled_position !! max |phi_l| / scale_l
        real(wp), intent(out), optional :: scaled_velocity !! max |(Phi H_p)_l| / scale_l
        real(wp), intent(out), optional :: velocity_field(:) !! H_p(q, p) (n), also for m = 0
        real(wp) :: phi(sys%m), hp(sys%n), hidden(sys%m), sparse_position, sparse_velocity
        real(wp), allocatable :: jac(:, :)
        integer, allocatable :: rows(:), columns(:)
        integer :: l, ios

        position = 0
        velocity = 0
        if (present(scaled_position)) scaled_position = 0
        if (present(scaled_velocity)) scaled_velocity = 0
        if (sys%m == 0) then
            if (present(velocity_field)) call sys%dh_dp(q, p, velocity_field)
            return
        end if
        if (int(sys%m, int64) * sys%n > dense_entries_limit) then
            call sys%constraint_sparsity(rows, columns)
            if (valid_pattern(rows, columns, sys%m, sys%n)) then
                call sparse_manifold_residuals(sys, rows, columns, q, p, position, velocity, &
                    sparse_position, sparse_velocity, velocity_field)
                if (present(scaled_position)) scaled_position = sparse_position
                if (present(scaled_velocity)) scaled_velocity = sparse_velocity
                return
            end if
        end if
        ios = 1
        if (int(sys%m, int64) * sys%n <= huge(0)) allocate (jac(sys%m, sys%n), stat=ios)
        if (ios /= 0) then
            if (present(velocity_field)) call sys%dh_dp(q, p, velocity_field)
            call not_finite(position, velocity, scaled_position, scaled_velocity)
            return
        end if
        call sys%constraint(q, phi)
        call sys%constraint_jacobian(q, jac)
        call sys%dh_dp(q, p, hp)
        if (present(velocity_field)) velocity_field = hp
        if (.not. (all(is_finite(phi)) .and. all(is_finite(jac)) .and. all(is_finite(hp)))) then
            call not_finite(position, velocity, scaled_position, scaled_velocity)
            return
        end if
        hidden = matmul(jac, hp)
        position = maxval(abs(phi))
        velocity = maxval(abs(hidden))
        do l = 1, sys%m
            if (present(scaled_position)) scaled_position = max(scaled_position, &
                abs(phi(l)) / (1 + maxval(abs(q)) * maxval(abs(jac(l, :)))))
            if (present(scaled_velocity)) scaled_velocity = max(scaled_velocity, &
                abs(hidden(l)) / (1 + sum(abs(jac(l, :)) * abs(hp))))
        end do
    end subroutine manifold_residuals

    !> Whether a declared pattern of Phi is one to use: entries in range, fewer than m n.
    pure logical function valid_pattern(rows, columns, m, n) result(valid)
        integer, intent(in) :: rows(:), columns(:) !! the pattern
        integer, intent(in) :: m, n                !! the shape of Phi
        valid = .false.
        if (size(rows) /= size(columns) .or. size(rows) == 0) return
        if (int(size(rows), int64) >= int(m, int64) * n) return
        valid = all(rows >= 1 .and. rows <= m) .and. all(columns >= 1 .and. columns <= n)
    end function valid_pattern

    !> `manifold_residuals` for a system with a sparse constraint Jacobian: Phi from
    !! `constraint_jacobian_values` at the pattern (rows, columns) of `constraint_sparsity`
    !! (no m x n matrix is formed). Same results.
    subroutine sparse_manifold_residuals(sys, rows, columns, q, p, position, velocity, &
                                         scaled_position, scaled_velocity, velocity_field)
        class(constrained_hamiltonian), intent(in) :: sys !! the system
        integer, intent(in) :: rows(:)     !! pattern of Phi: constraint of each entry
        integer, intent(in) :: columns(:)  !! pattern of Phi: coordinate of each entry
        real(wp), intent(in) :: q(:)  !! coordinates (n)
        real(wp), intent(in) :: p(:)  !! momenta (n)
        real(wp), intent(out) :: position  !! max |phi_l(q)|
        real(wp), intent(out) :: velocity  !! max |(Phi(q) H_p(q,p))_l|
        real(wp), intent(out) :: scaled_position !! max |phi_l| / scale_l
        real(wp), intent(out) :: scaled_velocity !! max |(Phi H_p)_l| / scale_l
        real(wp), intent(out), optional :: velocity_field(:) !! H_p(q, p) (n), also for m = 0
        real(wp), allocatable :: phi(:), values(:), hp(:), hidden(:), row_sum(:)
        integer :: e, l
        position = 0
        velocity = 0
        scaled_position = 0
        scaled_velocity = 0
        if (sys%m == 0) then
            if (present(velocity_field)) call sys%dh_dp(q, p, velocity_field)
            return
        end if
        allocate (phi(sys%m), values(size(rows)), hp(sys%n), hidden(sys%m), row_sum(sys%m))
        call sys%constraint(q, phi)
        call sys%constraint_jacobian_values(q, rows, columns, values)
        call sys%dh_dp(q, p, hp)
        if (present(velocity_field)) velocity_field = hp
        if (.not. (all(is_finite(phi)) .and. all(is_finite(values)) .and. &
                   all(is_finite(hp)))) then
            call not_finite(position, velocity, scaled_position, scaled_velocity)
            return
        end if
        hidden = 0
        row_sum = 0
        do e = 1, size(rows)
            l = rows(e)
            hidden(l) = hidden(l) + values(e) * hp(columns(e))
            row_sum(l) = row_sum(l) + abs(values(e)) * abs(hp(columns(e)))
        end do
        position = maxval(abs(phi))
        velocity = maxval(abs(hidden))
        scaled_position = sparse_scaled_position(q, phi, rows, values)
        scaled_velocity = maxval(abs(hidden) / (1 + row_sum))
    end subroutine sparse_manifold_residuals

    !> The scaled residual of phi, max_l |phi_l| / (1 + |q| max_c |Phi_lc|), from Phi's
    !! values on its pattern (constraint `rows(e)` of entry e).
    pure real(wp) function sparse_scaled_position(q, phi, rows, values) result(scaled)
        real(wp), intent(in) :: q(:)      !! coordinates (n)
        real(wp), intent(in) :: phi(:)    !! phi(q) (m)
        integer, intent(in) :: rows(:)    !! pattern of Phi: constraint of each entry
        real(wp), intent(in) :: values(:) !! Phi on its pattern
        real(wp) :: row_max(size(phi))
        integer :: e
        row_max = 0
        do e = 1, size(rows)
            row_max(rows(e)) = max(row_max(rows(e)), abs(values(e)))
        end do
        scaled = maxval(abs(phi) / (1 + maxval(abs(q)) * row_max))
    end function sparse_scaled_position

    !> All residuals NaN: the system returned a NaN or infinite value (the callers report
    !! it); computing with it would raise IEEE exceptions (0 * Inf).
    subroutine not_finite(position, velocity, scaled_position, scaled_velocity)
        real(wp), intent(out) :: position, velocity
        real(wp), intent(out), optional :: scaled_position, scaled_velocity
        position = ieee_value(position, ieee_quiet_nan)
        velocity = position
        if (present(scaled_position)) scaled_position = position
        if (present(scaled_velocity)) scaled_velocity = position
    end subroutine not_finite

    !> `full_rank_constraints` for a sparse Phi: the Cholesky factorisation of Phi Phi^T in
    !! band storage, constraints taken in `order` (for which the Gram matrix should be
    !! banded); a pivot below m epsilon times the largest diagonal entry means rank
    !! deficient, as for the dense test. Work and memory grow like m times the band squared.
    function sparse_full_rank_constraints(sys, rows, columns, order, q, message, threshold, &
                                          finite) result(full_rank)
        class(constrained_hamiltonian), intent(in) :: sys !! the system
        integer, intent(in) :: rows(:)     !! pattern of Phi: constraint of each entry
        integer, intent(in) :: columns(:)  !! pattern of Phi: coordinate of each entry
        integer, intent(in) :: order(:)    !! position of each constraint in the factorisation
        real(wp), intent(in) :: q(:)       !! coordinates (n)
        character(len=:), allocatable, intent(out) :: message !! why not, or empty
        !> Relative pivot threshold of Phi Phi^T (default m epsilon).
        real(wp), intent(in), optional :: threshold
        !> False when Phi is not finite at q (the result is then true: no dependence found).
        logical, intent(out), optional :: finite
        logical :: full_rank
        real(wp), allocatable :: values(:), band(:, :)
        real(wp) :: relative
        integer :: failed
        message = ""
        full_rank = .true.
        if (present(finite)) finite = .true.
        if (sys%m == 0) return
        allocate (values(size(rows)))
        call sys%constraint_jacobian_values(q, rows, columns, values)
        if (.not. all(is_finite(values))) then
            if (present(finite)) finite = .false.
            return
        end if
        call gram_band(sys%n, sys%m, rows, columns, order, values, band)
        relative = sys%m * epsilon(1.0_wp)
        if (present(threshold)) relative = threshold
        call band_cholesky(band, relative, failed)
        if (failed > 0) then
            full_rank = .false.
            message = "the constraint Jacobian Phi is rank deficient at q: a constraint " &
                // "is (nearly) a combination of the others (pivot " // int_str(failed) // &
                " of " // int_str(sys%m) // " of Phi Phi^T below " // &
                real_str(relative) // " relative)"
        end if
    end function sparse_full_rank_constraints

    !> The Gram matrix G = Phi W Phi^T (m x m) of a sparse Phi (its entries `values` on the
    !! pattern `rows`, `columns`), W = diag(`weights`) or the identity, in lower band
    !! storage for the constraints taken in `order`: band(1 + i - j, j) = G(i, j) for the
    !! ordered indices i >= j, the band as wide as the pattern makes it (two constraints
    !! are coupled when they share a coordinate). Work: the pairs of entries per coordinate.
    pure subroutine gram_band(n, m, rows, columns, order, values, band, weights)
        integer, intent(in) :: n, m        !! coordinates, constraints
        integer, intent(in) :: rows(:)     !! pattern of Phi: constraint of each entry
        integer, intent(in) :: columns(:)  !! pattern of Phi: coordinate of each entry
        integer, intent(in) :: order(:)    !! position of each constraint in the band order
        real(wp), intent(in) :: values(:)  !! Phi on its pattern
        real(wp), allocatable, intent(out) :: band(:, :) !! (width + 1, m)
        real(wp), intent(in), optional :: weights(:) !! W's diagonal (n)
        integer, allocatable :: start(:), entry(:), fill(:)
        integer :: e, f, c, a, b, width, i, j
        real(wp) :: w
        ! Entries of each coordinate (column), to pair the constraints that share it.
        allocate (start(n + 1), fill(n), entry(size(rows)))
        fill = 0
        do e = 1, size(rows)
            fill(columns(e)) = fill(columns(e)) + 1
        end do
        start(1) = 1
        do c = 1, n
            start(c + 1) = start(c) + fill(c)
        end do
        fill = start(1:n)
        do e = 1, size(rows)
            entry(fill(columns(e))) = e
            fill(columns(e)) = fill(columns(e)) + 1
        end do
        width = 0
        do c = 1, n
            do a = start(c), start(c + 1) - 1
                do b = start(c), start(c + 1) - 1
                    width = max(width, abs(order(rows(entry(a))) - order(rows(entry(b)))))
                end do
            end do
        end do
        allocate (band(width + 1, m))
        band = 0
        do c = 1, n
            w = 1
            if (present(weights)) w = weights(c)
            do a = start(c), start(c + 1) - 1
                do b = start(c), start(c + 1) - 1
                    e = entry(a)
                    f = entry(b)
                    i = order(rows(e))
                    j = order(rows(f))
                    if (i >= j) band(1 + i - j, j) = band(1 + i - j, j) + values(e) * w * values(f)
                end do
            end do
        end do
    end subroutine gram_band

    !> Cholesky factorisation L L^T of a symmetric band matrix in the lower band storage of
    !! `gram_band`, in place (L in the band). `failed` is 0, or the first pivot (in the
    !! band order) at or below `relative` times the largest diagonal entry: the matrix is
    !! then (nearly) singular, the band only partly factored.
    pure subroutine band_cholesky(band, relative, failed)
        real(wp), intent(inout) :: band(:, :) !! (width + 1, m): the matrix in, L out
        real(wp), intent(in) :: relative      !! relative pivot threshold
        integer, intent(out) :: failed        !! 0 or the failing pivot
        real(wp) :: cutoff
        integer :: width, m, i, j, k
        width = size(band, 1) - 1
        m = size(band, 2)
        failed = 0
        cutoff = relative * maxval(band(1, :))
        do j = 1, m
            if (.not. band(1, j) > cutoff) then
                failed = j
                return
            end if
            band(1, j) = sqrt(band(1, j))
            do i = 2, min(width + 1, m - j + 1)
                band(i, j) = band(i, j) / band(1, j)
            end do
            do k = 2, min(width + 1, m - j + 1)
                do i = k, min(width + 1, m - j + 1)
                    band(i - k + 1, j + k - 1) = band(i - k + 1, j + k - 1) - &
                        band(i, j) * band(k, j)
                end do
            end do
        end do
    end subroutine band_cholesky

    !> Solve G y = x with the factor L of `band_cholesky`, in place; x and y indexed by
    !! constraint (G's rows and columns in `order`).
    pure subroutine band_cholesky_solve(band, order, x)
        real(wp), intent(in) :: band(:, :)   !! L from `band_cholesky`
        integer, intent(in) :: order(:)      !! position of each constraint in the band order
        real(wp), intent(inout) :: x(:)      !! right-hand side in, solution out
        real(wp) :: y(size(x))
        integer :: width, m, i, j
        width = size(band, 1) - 1
        m = size(band, 2)
        y(order) = x
        do j = 1, m
            y(j) = y(j) / band(1, j)
            do i = j + 1, min(j + width, m)
                y(i) = y(i) - band(1 + i - j, j) * y(j)
            end do
        end do
        do j = m, 1, -1
            do i = j + 1, min(j + width, m)
                y(j) = y(j) - band(1 + i - j, j) * y(i)
            end do
            y(j) = y(j) / band(1, j)
        end do
        x = y(order)
    end subroutine band_cholesky_solve

    !> True when Phi(q) has full row rank m: the LU of Phi Phi^T (m x m) finds no pivot
    !! below m epsilon relative, i.e. no singular value of Phi below ~sqrt(m epsilon) relative.
    !! Otherwise `message` says which constraint is (nearly) dependent on the others.
    function full_rank_constraints(sys, q, message, threshold, finite) result(full_rank)
        class(constrained_hamiltonian), intent(in) :: sys !! the system
        real(wp), intent(in) :: q(:) !! coordinates (n)
        character(len=:), allocatable, intent(out) :: message !! why not, or empty
        !> Relative pivot threshold of Phi Phi^T (default m epsilon).
        real(wp), intent(in), optional :: threshold
        !> False when Phi is not finite at q (the result is then true: no dependence found).
        logical, intent(out), optional :: finite
        logical :: full_rank
        real(wp) :: jac(sys%m, sys%n), gram(sys%m, sys%m), relative
        integer :: pivots(sys%m), info
        message = ""
        full_rank = .true.
        if (present(finite)) finite = .true.
        if (sys%m == 0) return
        call sys%constraint_jacobian(q, jac)
        if (.not. all(is_finite(jac))) then
            if (present(finite)) finite = .false.
            return
        end if
        gram = matmul(jac, transpose(jac))
        relative = sys%m * epsilon(1.0_wp)
        if (present(threshold)) relative = threshold
        call lu_factor(gram, pivots, info, relative)
        full_rank = info == 0
        if (.not. full_rank) message = "the constraint Jacobian Phi is rank deficient at q: " &
            // "constraint " // int_str(info) // " of " // int_str(sys%m) // " is (nearly) " // &
            "a combination of the others (pivot of Phi Phi^T below " // real_str(relative) // &
            " relative)"
    end function full_rank_constraints

end module holosym_manifold
