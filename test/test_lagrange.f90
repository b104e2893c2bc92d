!> Tests of the lagrange part of holosym: basis values, derivatives and matrices.
module test_lagrange
    use holosym_kinds, only: wp
    use holosym_status_codes, only: int_str
    use holosym_quadrature, only: gauss_lobatto, gauss_legendre
    use holosym_lagrange, only: lagrange_values, lagrange_derivatives, lagrange_matrices
    use holosym_testing, only: test_case_t, new_test, test_error_t, check, check_close
    implicit none
    private
    public :: lagrange_tests

    real(wp), parameter :: eps = epsilon(1.0_wp)
    !> Round-off allowed in sums of basis values (scaled by their magnitude).
    real(wp), parameter :: tolerance = 256 * eps
    !> Arbitrary distinct nodes, unsorted and partly outside [0, 1].
    real(wp), parameter :: odd_nodes(6) = [0.3_wp, -0.45_wp, 1.2_wp, 0.71_wp, 0.05_wp, 0.9_wp]
    !> Evaluation points (not nodes), inside and slightly outside [0, 1].
    real(wp), parameter :: points(7) = [-0.1_wp, 0.0625_wp, 0.2_wp, 0.37_wp, 0.5_wp + 1.0e-3_wp, &
                                        0.83_wp, 1.05_wp]

contains

    !> The tests of this suite.
    function lagrange_tests() result(tests)
        type(test_case_t), allocatable :: tests(:)
        tests = [ &
            new_test("cardinal_at_lobatto_nodes", cardinal_lobatto), &
            new_test("cardinal_at_arbitrary_nodes", cardinal_arbitrary), &
            new_test("partition_of_unity", partition_of_unity), &
            new_test("derivatives_sum_to_zero", derivatives_sum_zero), &
            new_test("reproduces_polynomials_values", reproduces_values), &
            new_test("reproduces_polynomials_derivatives", reproduces_derivatives), &
            new_test("does_not_reproduce_degree_k", not_degree_k), &
            new_test("derivatives_match_barycentric_off_nodes", barycentric_off_nodes), &
            new_test("derivatives_match_differentiation_matrix", differentiation_matrix), &
            new_test("closed_form_two_and_three_nodes", closed_form_small), &
            new_test("matrices_match_vectors", matrices_match_vectors) &
            ]
    end function lagrange_tests

    ! ------------------------------------------------------------------ helpers

    !> Lobatto nodes on [0, 1] with k points.
    function lobatto_nodes(k) result(nodes)
        integer, intent(in) :: k !! number of nodes >= 2
        real(wp) :: nodes(k)
        real(wp) :: weights(k)
        call gauss_lobatto(nodes, weights)
    end function lobatto_nodes

    !> Barycentric weights 1 / prod_{j /= i} (x_i - x_j).
    pure function barycentric_weights(nodes) result(weights)
        real(wp), intent(in) :: nodes(:) !! distinct nodes
        real(wp) :: weights(size(nodes))
        integer :: i, j
        do i = 1, size(nodes)
            weights(i) = 1
            do j = 1, size(nodes)
                if (j /= i) weights(i) = weights(i) / (nodes(i) - nodes(j))
            end do
        end do
    end function barycentric_weights

    !> Value of the polynomial sum_k coef(k) tau^(k-1) (Horner).
    pure real(wp) function poly_value(coef, tau)
        real(wp), intent(in) :: coef(:) !! coefficients of 1, tau, tau^2, ...
        real(wp), intent(in) :: tau     !! abscissa
        integer :: k
        poly_value = 0
        do k = size(coef), 1, -1
            poly_value = poly_value * tau + coef(k)
        end do
    end function poly_value

    !> Derivative of the polynomial sum_k coef(k) tau^(k-1), in closed form.
    pure real(wp) function poly_derivative(coef, tau)
        real(wp), intent(in) :: coef(:) !! coefficients of 1, tau, tau^2, ...
        real(wp), intent(in) :: tau     !! abscissa
        integer :: k
        poly_derivative = 0
        do k = size(coef), 2, -1
            poly_derivative = poly_derivative * tau + (k - 1) * coef(k)
        end do
    end function poly_derivative

    !> A fixed set of coefficients in [-1, 1] (deterministic, no random state).
    pure function test_coefficients(k) result(coef)
        integer, intent(in) :: k !! number of coefficients
        real(wp) :: coef(k)
        integer :: i
        do i = 1, k
            coef(i) = sin(1.7_wp * i + 0.3_wp)
        end do
    end function test_coefficients

    ! ------------------------------------------------------------------ tests

    !> rho_i(x_j) is exactly delta_ij on Lobatto nodes, k = 2..12.
    subroutine cardinal_lobatto(error)
        type(test_error_t), allocatable, intent(out) :: error
        integer :: k, i, j
        real(wp), allocatable :: nodes(:), values(:)
        do k = 2, 12
            nodes = lobatto_nodes(k)
            do j = 1, k
                values = lagrange_values(nodes, nodes(j))
                do i = 1, k
                    call check(error, values(i) == merge(1.0_wp, 0.0_wp, i == j), "K = " // &
                        int_str(k) // ": rho_" // int_str(i) // "(x_" // int_str(j) // &
                        ") is not exactly delta")
                end do
                if (allocated(error)) return
            end do
        end do
    end subroutine cardinal_lobatto

    !> rho_i(x_j) is exactly delta_ij on arbitrary (unsorted, spread) distinct nodes.
    subroutine cardinal_arbitrary(error)
        type(test_error_t), allocatable, intent(out) :: error
        integer :: i, j, k
        real(wp) :: values(size(odd_nodes))
        do k = 1, size(odd_nodes)
            do j = 1, k
                values(1:k) = lagrange_values(odd_nodes(1:k), odd_nodes(j))
                do i = 1, k
                    call check(error, values(i) == merge(1.0_wp, 0.0_wp, i == j), "K = " // &
                        int_str(k) // ": rho_" // int_str(i) // "(x_" // int_str(j) // &
                        ") is not exactly delta")
                end do
                if (allocated(error)) return
            end do
        end do
    end subroutine cardinal_arbitrary

    !> sum_i rho_i(tau) = 1 at non-node points, Lobatto k = 1..16 and arbitrary nodes.
    subroutine partition_of_unity(error)
        type(test_error_t), allocatable, intent(out) :: error
        integer :: k, g
        real(wp), allocatable :: nodes(:), values(:)
        do k = 2, 16
            nodes = lobatto_nodes(k)
            do g = 1, size(points)
                values = lagrange_values(nodes, points(g))
                call check_close(error, sum(values), 1.0_wp, 0.0_wp, tolerance * &
                    maxval(abs(values)), "Lobatto K = " // int_str(k) // ", sum of rho_i")
            end do
            if (allocated(error)) return
        end do
        do g = 1, size(points)
            values = lagrange_values(odd_nodes, points(g))
            call check_close(error, sum(values), 1.0_wp, 0.0_wp, tolerance * &
                maxval(abs(values)), "arbitrary nodes, sum of rho_i")
        end do
        call check_close(error, sum(lagrange_values([0.25_wp], 0.7_wp)), 1.0_wp, 0.0_wp, 0.0_wp, &
            "one node: rho_1 = 1")
    end subroutine partition_of_unity

    !> sum_i rho_i'(tau) = 0 at nodes and non-node points.
    subroutine derivatives_sum_zero(error)
        type(test_error_t), allocatable, intent(out) :: error
        integer :: k, g
        real(wp), allocatable :: nodes(:), derivs(:)
        do k = 2, 16
            nodes = lobatto_nodes(k)
            do g = 1, size(points)
                derivs = lagrange_derivatives(nodes, points(g))
                call check_close(error, sum(derivs), 0.0_wp, 0.0_wp, tolerance * &
                    maxval(abs(derivs)), "Lobatto K = " // int_str(k) // ", sum of rho_i'")
            end do
            do g = 1, k
                derivs = lagrange_derivatives(nodes, nodes(g))
                call check_close(error, sum(derivs), 0.0_wp, 0.0_wp, tolerance * &
                    maxval(abs(derivs)), "Lobatto K = " // int_str(k) // ", sum of rho_i' at node")
            end do
            if (allocated(error)) return
        end do
        derivs = lagrange_derivatives(odd_nodes, 0.4_wp)
        call check_close(error, sum(derivs), 0.0_wp, 0.0_wp, tolerance * maxval(abs(derivs)), &
            "arbitrary nodes, sum of rho_i'")
        call check(error, all(lagrange_derivatives([0.25_wp], 0.7_wp) == 0.0_wp), &
            "one node: rho_1' must be 0")
    end subroutine derivatives_sum_zero

    !> sum_i f(x_i) rho_i(tau) = f(tau) for every polynomial f of degree <= K-1.
    subroutine reproduces_values(error)
        type(test_error_t), allocatable, intent(out) :: error
        integer :: k, degree, g
        real(wp), allocatable :: nodes(:), coef(:), samples(:), terms(:)
        real(wp) :: exact
        do k = 2, 12
            nodes = lobatto_nodes(k)
            do degree = 0, k - 1
                coef = test_coefficients(degree + 1)
                samples = [(poly_value(coef, nodes(g)), g = 1, k)]
                do g = 1, size(points)
                    terms = samples * lagrange_values(nodes, points(g))
                    exact = poly_value(coef, points(g))
                    ! Round-off scales with sum |f_i rho_i| (large when extrapolating).
                    call check_close(error, sum(terms), exact, tolerance, tolerance * &
                        sum(abs(terms)), "K = " // int_str(k) // ", degree " // &
                        int_str(degree) // ", interpolated value")
                end do
                if (allocated(error)) return
            end do
        end do
        coef = test_coefficients(size(odd_nodes))
        samples = [(poly_value(coef, odd_nodes(g)), g = 1, size(odd_nodes))]
        do g = 1, size(points)
            call check_close(error, sum(samples * lagrange_values(odd_nodes, points(g))), &
                poly_value(coef, points(g)), 0.0_wp, 4 * tolerance * sum(abs(samples)), &
                "arbitrary nodes, interpolated value")
        end do
    end subroutine reproduces_values

    !> sum_i f(x_i) rho_i'(tau) = f'(tau) (closed form) for every f of degree <= K-1.
    subroutine reproduces_derivatives(error)
        type(test_error_t), allocatable, intent(out) :: error
        integer :: k, degree, g
        real(wp), allocatable :: nodes(:), coef(:), samples(:), terms(:)
        real(wp) :: exact
        do k = 2, 12
            nodes = lobatto_nodes(k)
            do degree = 0, k - 1
                coef = test_coefficients(degree + 1)
                samples = [(poly_value(coef, nodes(g)), g = 1, k)]
                do g = 1, size(points)
                    terms = samples * lagrange_derivatives(nodes, points(g))
                    exact = poly_derivative(coef, points(g))
                    call check_close(error, sum(terms), exact, tolerance, tolerance * k * &
                        sum(abs(terms)), "K = " // int_str(k) // ", degree " // &
                        int_str(degree) // ", interpolated derivative")
                end do
                if (allocated(error)) return
            end do
        end do
        coef = test_coefficients(size(odd_nodes))
        samples = [(poly_value(coef, odd_nodes(g)), g = 1, size(odd_nodes))]
        do g = 1, size(points)
            call check_close(error, sum(samples * lagrange_derivatives(odd_nodes, points(g))), &
                poly_derivative(coef, points(g)), 0.0_wp, 64 * tolerance * sum(abs(samples)), &
                "arbitrary nodes, interpolated derivative")
        end do
    end subroutine reproduces_derivatives

    !> tau^K is NOT reproduced by K nodes (the reproduction tests could fail).
    subroutine not_degree_k(error)
        type(test_error_t), allocatable, intent(out) :: error
        integer :: k, g
        real(wp), allocatable :: nodes(:)
        real(wp) :: interpolated
        do k = 2, 8
            nodes = lobatto_nodes(k)
            interpolated = sum([(nodes(g)**k, g = 1, k)] * lagrange_values(nodes, 0.37_wp))
            ! The interpolation error is tau^K minus its interpolant: prod (tau - x_i) /= 0.
            call check_close(error, 0.37_wp**k - interpolated, product(0.37_wp - nodes), &
                0.0_wp, tolerance, "K = " // int_str(k) // ": error of interpolating tau^K")
            call check(error, abs(product(0.37_wp - nodes)) > 1.0e6_wp * tolerance, &
                "K = " // int_str(k) // ": nodal polynomial too small to show the error")
            if (allocated(error)) return
        end do
    end subroutine not_degree_k

    !> Off the nodes, rho_i'(tau) = rho_i(tau) sum_{j /= i} 1/(tau - x_j) (logarithmic
    !! derivative), with rho_i(tau) from the barycentric formula l(tau) w_i / (tau - x_i).
    subroutine barycentric_off_nodes(error)
        type(test_error_t), allocatable, intent(out) :: error
        integer :: k, g, i
        real(wp), allocatable :: nodes(:), weights(:), derivs(:), values(:)
        real(wp) :: nodal, bary_value, bary_deriv, tau
        do k = 1, 14
            if (k == 1) then
                nodes = [0.4_wp]
            else
                nodes = lobatto_nodes(k)
            end if
            call check_nodes(nodes, "Lobatto K = " // int_str(k))
            if (allocated(error)) return
        end do
        nodes = odd_nodes
        call check_nodes(nodes, "arbitrary nodes")

    contains

        subroutine check_nodes(x, label)
            real(wp), intent(in) :: x(:)          !! nodes
            character(len=*), intent(in) :: label !! for messages
            weights = barycentric_weights(x)
            do g = 1, size(points)
                tau = points(g)
                nodal = product(tau - x)
                values = lagrange_values(x, tau)
                derivs = lagrange_derivatives(x, tau)
                do i = 1, size(x)
                    bary_value = nodal * weights(i) / (tau - x(i))
                    bary_deriv = bary_value * (sum(1 / (tau - x)) - 1 / (tau - x(i)))
                    call check_close(error, values(i), bary_value, tolerance, tolerance, &
                        label // ", rho_" // int_str(i) // " against barycentric")
                    call check_close(error, derivs(i), bary_deriv, tolerance, &
                        tolerance * size(x)**2, label // ", rho_" // int_str(i) // &
                        "' against barycentric")
                end do
                if (allocated(error)) return
            end do
        end subroutine check_nodes

    end subroutine barycentric_off_nodes

    !> At the nodes, rho_i'(x_j) is the differentiation matrix (w_i/w_j)/(x_j - x_i), i /= j,
    !! and sum_{k /= j} 1/(x_j - x_k) on the diagonal.
    subroutine differentiation_matrix(error)
        type(test_error_t), allocatable, intent(out) :: error
        integer :: k
        do k = 2, 14
            call check_nodes(lobatto_nodes(k), "Lobatto K = " // int_str(k))
            if (allocated(error)) return
        end do
        call check_nodes(odd_nodes, "arbitrary nodes")

    contains

        subroutine check_nodes(x, label)
            real(wp), intent(in) :: x(:)          !! nodes
            character(len=*), intent(in) :: label !! for messages
            real(wp) :: weights(size(x)), derivs(size(x)), expected
            integer :: i, j, l
            weights = barycentric_weights(x)
            do j = 1, size(x)
                derivs = lagrange_derivatives(x, x(j))
                do i = 1, size(x)
                    if (i == j) then
                        expected = 0
                        do l = 1, size(x)
                            if (l /= j) expected = expected + 1 / (x(j) - x(l))
                        end do
                    else
                        expected = weights(i) / weights(j) / (x(j) - x(i))
                    end if
                    call check_close(error, derivs(i), expected, tolerance, &
                        tolerance * size(x)**2, label // ", rho_" // int_str(i) // "'(x_" // &
                        int_str(j) // ")")
                end do
                if (allocated(error)) return
            end do
        end subroutine check_nodes

    end subroutine differentiation_matrix

    !> Two nodes (0, 1): rho = (1 - tau, tau), rho' = (-1, 1).
    !! Three nodes (0, 1/2, 1): rho_1' = 4 tau - 3, rho_2' = 4 - 8 tau, rho_3' = 4 tau - 1.
    subroutine closed_form_small(error)
        type(test_error_t), allocatable, intent(out) :: error
        real(wp) :: v2(2), d2(2), d3(3), tau
        integer :: g
        do g = 1, size(points)
            tau = points(g)
            v2 = lagrange_values([0.0_wp, 1.0_wp], tau)
            d2 = lagrange_derivatives([0.0_wp, 1.0_wp], tau)
            call check_close(error, v2(1), 1 - tau, 0.0_wp, 2 * eps, "2 nodes: rho_1")
            call check_close(error, v2(2), tau, 0.0_wp, 2 * eps, "2 nodes: rho_2")
            call check_close(error, d2(1), -1.0_wp, 0.0_wp, 2 * eps, "2 nodes: rho_1'")
            call check_close(error, d2(2), 1.0_wp, 0.0_wp, 2 * eps, "2 nodes: rho_2'")
            d3 = lagrange_derivatives([0.0_wp, 0.5_wp, 1.0_wp], tau)
            call check_close(error, d3(1), 4 * tau - 3, 0.0_wp, 16 * eps, "3 nodes: rho_1'")
            call check_close(error, d3(2), 4 - 8 * tau, 0.0_wp, 16 * eps, "3 nodes: rho_2'")
            call check_close(error, d3(3), 4 * tau - 1, 0.0_wp, 16 * eps, "3 nodes: rho_3'")
            if (allocated(error)) return
        end do
    end subroutine closed_form_small

    !> lagrange_matrices(g, i) equals the vector routines at each point (bit for bit), and
    !! the rows of the matrices at Gauss points sum to 1 and 0.
    subroutine matrices_match_vectors(error)
        type(test_error_t), allocatable, intent(out) :: error
        real(wp) :: nodes(5), gauss(4), weights(5), gweights(4)
        real(wp) :: values(4, 5), derivs(4, 5)
        integer :: g
        call gauss_lobatto(nodes, weights)
        call gauss_legendre(gauss, gweights)
        call lagrange_matrices(nodes, gauss, values, derivs)
        do g = 1, 4
            call check(error, all(values(g, :) == lagrange_values(nodes, gauss(g))), &
                "values row " // int_str(g) // " differs from lagrange_values")
            call check(error, all(derivs(g, :) == lagrange_derivatives(nodes, gauss(g))), &
                "derivatives row " // int_str(g) // " differs from lagrange_derivatives")
            call check_close(error, sum(values(g, :)), 1.0_wp, 0.0_wp, tolerance, "row sum")
            call check_close(error, sum(derivs(g, :)), 0.0_wp, 0.0_wp, 16 * tolerance, &
                "derivative row sum")
        end do
        ! Gauss quadrature of rho_i (degree 4 <= 2*4-1) gives the Lobatto weights.
        do g = 1, 5
            call check_close(error, sum(gweights * values(:, g)), weights(g), 0.0_wp, tolerance, &
                "integral of rho_" // int_str(g) // " against Lobatto weight")
        end do
    end subroutine matrices_match_vectors

end module test_lagrange
