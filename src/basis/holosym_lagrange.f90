!> category: internal module (use holosym)
!! Lagrange interpolation basis on given nodes: values and tau-derivatives at given points.
!!
!! For nodes x_1..x_K, rho_i(tau) = prod_{j /= i} (tau - x_j)/(x_i - x_j). The product form
!! is used (not barycentric) so values at the nodes are exactly 0 or 1 and derivatives are
!! accurate everywhere; K is small (at most a few tens) in holosym.
module holosym_lagrange
    use holosym_kinds, only: wp
    implicit none
    private

    public :: lagrange_values, lagrange_derivatives, lagrange_matrices

contains

    !> Values rho_i(tau) of all basis polynomials at one point.
    pure function lagrange_values(nodes, tau) result(values)
        real(wp), intent(in) :: nodes(:) !! distinct interpolation nodes
        real(wp), intent(in) :: tau      !! evaluation point
        real(wp) :: values(size(nodes))
        integer :: i, j
        do i = 1, size(nodes)
            values(i) = 1
            do j = 1, size(nodes)
                if (j /= i) values(i) = values(i) * (tau - nodes(j)) / (nodes(i) - nodes(j))
            end do
        end do
    end function lagrange_values

    !> Derivatives d rho_i / d tau of all basis polynomials at one point.
    pure function lagrange_derivatives(nodes, tau) result(derivatives)
        real(wp), intent(in) :: nodes(:) !! distinct interpolation nodes
        real(wp), intent(in) :: tau      !! evaluation point
        real(wp) :: derivatives(size(nodes))
        real(wp) :: term
        integer :: i, j, k
        ! Product rule: drop one factor (tau - x_k) at a time.
        do i = 1, size(nodes)
            derivatives(i) = 0
            do k = 1, size(nodes)
                if (k == i) cycle
                term = 1 / (nodes(i) - nodes(k))
                do j = 1, size(nodes)
                    if (j /= i .and. j /= k) term = term * (tau - nodes(j)) / (nodes(i) - nodes(j))
                end do
                derivatives(i) = derivatives(i) + term
            end do
        end do
    end function lagrange_derivatives

    !> Basis values and derivatives at several points: `values(g, i) = rho_i(points(g))`,
    !! `derivatives(g, i) = rho_i'(points(g))`.
    pure subroutine lagrange_matrices(nodes, points, values, derivatives)
        real(wp), intent(in) :: nodes(:)  !! distinct interpolation nodes (K)
        real(wp), intent(in) :: points(:) !! evaluation points (P)
        real(wp), intent(out) :: values(:, :)      !! P x K matrix of values
        real(wp), intent(out) :: derivatives(:, :) !! P x K matrix of tau-derivatives
        integer :: g
        do g = 1, size(points)
            values(g, :) = lagrange_values(nodes, points(g))
            derivatives(g, :) = lagrange_derivatives(nodes, points(g))
        end do
    end subroutine lagrange_matrices

end module holosym_lagrange
