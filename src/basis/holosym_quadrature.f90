!> category: internal module (use holosym)
!! Gauss-Legendre and Gauss-Lobatto quadrature on [0, 1], computed in working precision.
!!
!! Nodes are found by Newton's method on Legendre polynomials (three-term recurrence),
!! never typed in, so they are accurate to working precision for any number of points.
!! The rules are symmetric about 1/2 by construction and the weights sum to 1.
module holosym_quadrature
    use holosym_kinds, only: wp
    use holosym_status_codes, only: holosym_status_t, set_status, int_str, &
                              HOLOSYM_SUCCESS, HOLOSYM_INVALID_ARGUMENT, HOLOSYM_SIZE_MISMATCH
    implicit none
    private

    public :: gauss_legendre, gauss_lobatto

    !> Newton on a node stops once the correction is below this (relative to 1).
    real(wp), parameter :: node_tolerance = epsilon(1.0_wp)
    !> Enough for quadratic convergence from the asymptotic first guesses.
    integer, parameter :: max_newton_iterations = 100

contains

    !> Gauss-Legendre rule with `size(nodes)` points on [0, 1]: exact for polynomials of
    !! degree up to 2G-1, where G = size(nodes) >= 1.
    pure subroutine gauss_legendre(nodes, weights, status)
        real(wp), intent(out) :: nodes(:)   !! G nodes in increasing order in (0, 1)
        real(wp), intent(out) :: weights(:) !! G positive weights summing to 1
        type(holosym_status_t), intent(out), optional :: status !! success or invalid size
        integer :: npts, i, iter
        real(wp) :: x, dx, p, dp, pi
        logical :: valid

        pi = 4 * atan(1.0_wp) ! here, not a named constant: real128 atan is not folded everywhere
        npts = size(nodes)
        call check_sizes("Gauss-Legendre", 1, nodes, weights, valid, status)
        if (.not. valid) return
        ! Roots of P_G in (-1, 1); compute the upper half and mirror it (exact symmetry).
        do i = 1, (npts + 1) / 2
            x = cos(pi * (i - 0.25_wp) / (npts + 0.5_wp))
            do iter = 1, max_newton_iterations
                call legendre(npts, x, p, dp)
                dx = p / dp
                x = x - dx
                if (abs(dx) <= node_tolerance) exit
            end do
            call legendre(npts, x, p, dp)
            ! x_i descending from near 1: map to tau = (1 -+ x)/2 for the two mirrored nodes.
            nodes(i) = (1 - x) / 2
            nodes(npts + 1 - i) = (1 + x) / 2
            weights(i) = 1 / ((1 - x**2) * dp**2)
            weights(npts + 1 - i) = weights(i)
        end do
        if (mod(npts, 2) == 1) nodes((npts + 1) / 2) = 0.5_wp
        call set_status(status, HOLOSYM_SUCCESS, "")
    end subroutine gauss_legendre

    !> Gauss-Lobatto rule with k = `size(nodes)` >= 2 points on [0, 1], both ends included:
    !! exact for polynomials of degree up to 2k-3.
    pure subroutine gauss_lobatto(nodes, weights, status)
        real(wp), intent(out) :: nodes(:)   !! k nodes, nodes(1) = 0, nodes(k) = 1, increasing
        real(wp), intent(out) :: weights(:) !! k positive weights summing to 1
        type(holosym_status_t), intent(out), optional :: status !! success or invalid size
        integer :: npts, degree, i, iter
        real(wp) :: x, dx, p, dp, d2p, pi
        logical :: valid

        pi = 4 * atan(1.0_wp) ! here, not a named constant: real128 atan is not folded everywhere
        npts = size(nodes)
        call check_sizes("Gauss-Lobatto", 2, nodes, weights, valid, status)
        if (.not. valid) return
        degree = npts - 1
        ! Interior nodes: roots of P'_{k-1}; weights 2/(k(k-1) P_{k-1}^2) on [-1, 1].
        nodes(1) = 0
        nodes(npts) = 1
        weights(1) = 1.0_wp / (npts * (npts - 1))
        weights(npts) = weights(1)
        do i = 2, (npts + 1) / 2
            x = cos(pi * (i - 1) / degree)
            do iter = 1, max_newton_iterations
                call legendre(degree, x, p, dp)
                ! Legendre's equation gives P'' from P and P'.
                d2p = (2 * x * dp - degree * (degree + 1) * p) / (1 - x**2)
                dx = dp / d2p
                x = x - dx
                if (abs(dx) <= node_tolerance) exit
            end do
            call legendre(degree, x, p, dp)
            nodes(i) = (1 - x) / 2
            nodes(npts + 1 - i) = (1 + x) / 2
            weights(i) = 1 / (npts * (npts - 1) * p**2)
            weights(npts + 1 - i) = weights(i)
        end do
        if (mod(npts, 2) == 1) nodes((npts + 1) / 2) = 0.5_wp
        call set_status(status, HOLOSYM_SUCCESS, "")
    end subroutine gauss_lobatto

    !> Check the sizes of a rule's arrays; on failure set `status` and return false.
    pure subroutine check_sizes(rule, min_points, nodes, weights, valid_sizes, status)
        character(len=*), intent(in) :: rule   !! name of the rule, for the message
        integer, intent(in) :: min_points      !! fewest points the rule has
        real(wp), intent(in) :: nodes(:), weights(:)
        logical, intent(out) :: valid_sizes
        type(holosym_status_t), intent(inout), optional :: status
        valid_sizes = .false.
        if (size(nodes) < min_points) then
            call set_status(status, HOLOSYM_INVALID_ARGUMENT, rule // " rule needs at least " &
                // int_str(min_points) // " point(s), got " // int_str(size(nodes)))
        else if (size(weights) /= size(nodes)) then
            call set_status(status, HOLOSYM_SIZE_MISMATCH, "weights has size " // &
                int_str(size(weights)) // ", nodes has size " // int_str(size(nodes)))
        else
            valid_sizes = .true.
        end if
    end subroutine check_sizes

    !> Legendre polynomial P_n and its derivative at x in (-1, 1), by the recurrence.
    pure subroutine legendre(n, x, p, dp)
        integer, intent(in) :: n     !! degree >= 1
        real(wp), intent(in) :: x    !! abscissa in (-1, 1)
        real(wp), intent(out) :: p   !! P_n(x)
        real(wp), intent(out) :: dp  !! P_n'(x)
        real(wp) :: p_prev, p_next
        integer :: k
        p_prev = 1
        p = x
        do k = 2, n
            p_next = ((2 * k - 1) * x * p - (k - 1) * p_prev) / k
            p_prev = p
            p = p_next
        end do
        dp = n * (p_prev - x * p) / (1 - x**2)
    end subroutine legendre

end module holosym_quadrature
