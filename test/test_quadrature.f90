!> Tests of the quadrature part of holosym: Gauss-Legendre and Gauss-Lobatto rules on [0, 1].
module test_quadrature
    use holosym_kinds, only: wp
    use holosym_status_codes, only: holosym_status_t, int_str, HOLOSYM_SUCCESS, &
        HOLOSYM_INVALID_ARGUMENT, HOLOSYM_SIZE_MISMATCH
    use holosym_quadrature, only: gauss_legendre, gauss_lobatto
    use holosym_testing, only: test_case_t, new_test, test_error_t, check, check_close, &
        check_status_code
    implicit none
    private
    public :: quadrature_tests

    real(wp), parameter :: eps = epsilon(1.0_wp)
    !> Largest rule size of the exhaustive tests.
    integer, parameter :: max_points = 20
    !> Round-off allowed in a quadrature sum of terms <= 1 (a few ulps per point).
    real(wp), parameter :: sum_tolerance = 64 * eps
    !> Smallest quadrature error whose value can be checked to relative 1e-6 against a sum
    !! carrying round-off sum_tolerance. All G, k <= 20 qualify in real128 (errors >= 1e-24);
    !! in real64 larger rules integrate the probe monomial exactly to round-off.
    real(wp), parameter :: resolvable_error = 1.0e6_wp * sum_tolerance

contains

    !> The tests of this suite.
    function quadrature_tests() result(tests)
        type(test_case_t), allocatable :: tests(:)
        tests = [ &
            new_test("legendre_exact_monomials_1_to_20", legendre_exact_monomials), &
            new_test("legendre_degree_2g_error_formula", legendre_degree_2g_error), &
            new_test("legendre_weights_positive_sum_one", legendre_weights), &
            new_test("legendre_nodes_increasing_symmetric", legendre_nodes), &
            new_test("legendre_closed_form_g1_g2_g3", legendre_closed_form), &
            new_test("legendre_30_points", legendre_30_points), &
            new_test("legendre_smooth_integrands", legendre_smooth_integrands), &
            new_test("lobatto_exact_monomials_2_to_20", lobatto_exact_monomials), &
            new_test("lobatto_degree_2k_minus_2_error_formula", lobatto_degree_2k_minus_2_error), &
            new_test("lobatto_weights_positive_sum_one", lobatto_weights), &
            new_test("lobatto_nodes_increasing_symmetric", lobatto_nodes), &
            new_test("lobatto_ends_exactly_0_and_1", lobatto_ends), &
            new_test("lobatto_closed_form_k2_k3_k4", lobatto_closed_form), &
            new_test("lobatto_30_points", lobatto_30_points), &
            new_test("legendre_zero_points_invalid", legendre_zero_points), &
            new_test("legendre_weights_size_mismatch", legendre_size_mismatch), &
            new_test("lobatto_too_few_points_invalid", lobatto_too_few_points), &
            new_test("lobatto_weights_size_mismatch", lobatto_size_mismatch) &
            ]
    end function quadrature_tests

    ! ------------------------------------------------------------------ helpers

    !> n! in working precision.
    pure real(wp) function factorial(n)
        integer, intent(in) :: n !! argument >= 0
        integer :: i
        factorial = 1
        do i = 2, n
            factorial = factorial * i
        end do
    end function factorial

    !> Check that a rule integrates tau^k, k = 0..degree, to round-off (exact 1/(k+1)).
    subroutine check_monomials(error, nodes, weights, degree, label)
        type(test_error_t), allocatable, intent(inout) :: error !! failure record
        real(wp), intent(in) :: nodes(:)    !! rule nodes
        real(wp), intent(in) :: weights(:)  !! rule weights
        integer, intent(in) :: degree       !! highest degree that must be exact
        character(len=*), intent(in) :: label !! rule name for the message
        integer :: k
        do k = 0, degree
            call check_close(error, sum(weights * nodes**k), 1.0_wp / (k + 1), 0.0_wp, &
                sum_tolerance, label // ", integral of tau^" // int_str(k))
            if (allocated(error)) return
        end do
    end subroutine check_monomials

    !> Check weights > 0 summing to 1, nodes strictly increasing in [0, 1] and symmetric.
    subroutine check_rule_shape(error, nodes, weights, label)
        type(test_error_t), allocatable, intent(inout) :: error !! failure record
        real(wp), intent(in) :: nodes(:)    !! rule nodes
        real(wp), intent(in) :: weights(:)  !! rule weights
        character(len=*), intent(in) :: label !! rule name for the message
        integer :: i, npts
        npts = size(nodes)
        call check(error, all(weights > 0), label // ": a weight is not positive")
        call check_close(error, sum(weights), 1.0_wp, 0.0_wp, sum_tolerance, &
            label // ": sum of weights")
        call check(error, all(nodes >= 0) .and. all(nodes <= 1), label // ": node outside [0,1]")
        call check(error, all(nodes(2:npts) > nodes(1:npts - 1)), &
            label // ": nodes not strictly increasing")
        do i = 1, npts
            call check_close(error, nodes(i) + nodes(npts + 1 - i), 1.0_wp, 0.0_wp, 2 * eps, &
                label // ": tau_i + tau_(n+1-i), i = " // int_str(i))
            call check_close(error, weights(i), weights(npts + 1 - i), 0.0_wp, 2 * eps, &
                label // ": w_i against w_(n+1-i), i = " // int_str(i))
            if (allocated(error)) return
        end do
    end subroutine check_rule_shape

    ! ------------------------------------------------------------------ Gauss-Legendre

    !> Exact to round-off on tau^k for k <= 2G-1, G = 1..20.
    subroutine legendre_exact_monomials(error)
        type(test_error_t), allocatable, intent(out) :: error
        integer :: g
        real(wp), allocatable :: nodes(:), weights(:)
        type(holosym_status_t) :: status
        do g = 1, max_points
            allocate (nodes(g), weights(g))
            call gauss_legendre(nodes, weights, status)
            call check_status_code(error, status%code, HOLOSYM_SUCCESS, &
                "gauss_legendre G = " // int_str(g))
            call check_monomials(error, nodes, weights, 2 * g - 1, "Gauss G = " // int_str(g))
            if (allocated(error)) return
            deallocate (nodes, weights)
        end do
    end subroutine legendre_exact_monomials

    !> tau^(2G) is NOT exact: the error equals (G!)^4 / ((2G+1) ((2G)!)^2) (positive).
    subroutine legendre_degree_2g_error(error)
        type(test_error_t), allocatable, intent(out) :: error
        integer :: g
        real(wp), allocatable :: nodes(:), weights(:)
        real(wp) :: quad_error, expected
        do g = 1, max_points
            allocate (nodes(g), weights(g))
            call gauss_legendre(nodes, weights)
            quad_error = 1.0_wp / (2 * g + 1) - sum(weights * nodes**(2 * g))
            expected = factorial(g)**4 / ((2 * g + 1) * factorial(2 * g)**2)
            ! Errors below round-off cannot be measured (only in real64, for G >= 7).
            if (expected <= resolvable_error) then
                call check(error, precision(1.0_wp) < 30 .and. g > 6, &
                    "Gauss G = " // int_str(g) // ": error formula below round-off")
                return
            end if
            call check(error, quad_error > resolvable_error, "Gauss G = " // int_str(g) &
                // " integrates tau^(2G) exactly: the degree test could never fail")
            call check_close(error, quad_error, expected, 1.0e-6_wp, 0.0_wp, &
                "Gauss G = " // int_str(g) // ", error on tau^(2G)")
            if (allocated(error)) return
            deallocate (nodes, weights)
        end do
    end subroutine legendre_degree_2g_error

    !> Weights positive and summing to 1, for G = 1..30.
    subroutine legendre_weights(error)
        type(test_error_t), allocatable, intent(out) :: error
        integer :: g
        real(wp), allocatable :: nodes(:), weights(:)
        do g = 1, 30
            allocate (nodes(g), weights(g))
            call gauss_legendre(nodes, weights)
            call check(error, all(weights > 0), "Gauss G = " // int_str(g) // ": weight <= 0")
            call check_close(error, sum(weights), 1.0_wp, 0.0_wp, sum_tolerance, &
                "Gauss G = " // int_str(g) // ": sum of weights")
            if (allocated(error)) return
            deallocate (nodes, weights)
        end do
    end subroutine legendre_weights

    !> Nodes strictly increasing, inside (0, 1), symmetric about 1/2, for G = 1..30.
    subroutine legendre_nodes(error)
        type(test_error_t), allocatable, intent(out) :: error
        integer :: g
        real(wp), allocatable :: nodes(:), weights(:)
        do g = 1, 30
            allocate (nodes(g), weights(g))
            call gauss_legendre(nodes, weights)
            call check(error, all(nodes > 0) .and. all(nodes < 1), &
                "Gauss G = " // int_str(g) // ": a node is not inside (0, 1)")
            call check_rule_shape(error, nodes, weights, "Gauss G = " // int_str(g))
            if (allocated(error)) return
            deallocate (nodes, weights)
        end do
    end subroutine legendre_nodes

    !> G = 1: (1/2; 1); G = 2: 1/2 -+ sqrt(3)/6, weights 1/2; G = 3: 1/2, 1/2 -+ sqrt(15)/10,
    !! weights 5/18, 8/18, 5/18.
    subroutine legendre_closed_form(error)
        type(test_error_t), allocatable, intent(out) :: error
        real(wp) :: n1(1), w1(1), n2(2), w2(2), n3(3), w3(3)
        call gauss_legendre(n1, w1)
        call check_close(error, n1(1), 0.5_wp, 0.0_wp, eps, "G = 1 node")
        call check_close(error, w1(1), 1.0_wp, 0.0_wp, eps, "G = 1 weight")
        call gauss_legendre(n2, w2)
        call check_close(error, n2(1), 0.5_wp - sqrt(3.0_wp) / 6, 0.0_wp, 2 * eps, "G = 2 node 1")
        call check_close(error, n2(2), 0.5_wp + sqrt(3.0_wp) / 6, 0.0_wp, 2 * eps, "G = 2 node 2")
        call check_close(error, w2(1), 0.5_wp, 0.0_wp, 2 * eps, "G = 2 weight 1")
        call check_close(error, w2(2), 0.5_wp, 0.0_wp, 2 * eps, "G = 2 weight 2")
        call gauss_legendre(n3, w3)
        call check_close(error, n3(1), 0.5_wp - sqrt(15.0_wp) / 10, 0.0_wp, 2 * eps, "G = 3 node 1")
        call check_close(error, n3(2), 0.5_wp, 0.0_wp, 2 * eps, "G = 3 node 2")
        call check_close(error, n3(3), 0.5_wp + sqrt(15.0_wp) / 10, 0.0_wp, 2 * eps, "G = 3 node 3")
        call check_close(error, w3(1), 5.0_wp / 18, 0.0_wp, 2 * eps, "G = 3 weight 1")
        call check_close(error, w3(2), 8.0_wp / 18, 0.0_wp, 2 * eps, "G = 3 weight 2")
        call check_close(error, w3(3), 5.0_wp / 18, 0.0_wp, 2 * eps, "G = 3 weight 3")
    end subroutine legendre_closed_form

    !> 30 points: exact on tau^k up to k = 59 and shape checks (the error on tau^60,
    !! about 1e-36, is below round-off, so degree 60 cannot be told apart here).
    subroutine legendre_30_points(error)
        type(test_error_t), allocatable, intent(out) :: error
        real(wp) :: nodes(30), weights(30)
        type(holosym_status_t) :: status
        call gauss_legendre(nodes, weights, status)
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, "gauss_legendre G = 30")
        call check_monomials(error, nodes, weights, 59, "Gauss G = 30")
        call check_rule_shape(error, nodes, weights, "Gauss G = 30")
    end subroutine legendre_30_points

    !> Smooth non-polynomial integrands are integrated to round-off with 20 and 30 points.
    subroutine legendre_smooth_integrands(error)
        type(test_error_t), allocatable, intent(out) :: error
        real(wp) :: n20(20), w20(20), n30(30), w30(30), pi
        pi = 4 * atan(1.0_wp)
        call gauss_legendre(n20, w20)
        call gauss_legendre(n30, w30)
        call check_close(error, sum(w20 * exp(n20)), exp(1.0_wp) - 1, 0.0_wp, sum_tolerance, &
            "G = 20, integral of exp")
        call check_close(error, sum(w30 * exp(n30)), exp(1.0_wp) - 1, 0.0_wp, sum_tolerance, &
            "G = 30, integral of exp")
        call check_close(error, sum(w30 * sin(pi * n30)), 2 / pi, 0.0_wp, sum_tolerance, &
            "G = 30, integral of sin(pi tau)")
        call check_close(error, sum(w30 / (1 + n30**2)), pi / 4, 0.0_wp, sum_tolerance, &
            "G = 30, integral of 1/(1+tau^2)")
    end subroutine legendre_smooth_integrands

    ! ------------------------------------------------------------------ Gauss-Lobatto

    !> Exact to round-off on tau^k for k <= 2k-3, k = 2..20 points.
    subroutine lobatto_exact_monomials(error)
        type(test_error_t), allocatable, intent(out) :: error
        integer :: k
        real(wp), allocatable :: nodes(:), weights(:)
        type(holosym_status_t) :: status
        do k = 2, max_points
            allocate (nodes(k), weights(k))
            call gauss_lobatto(nodes, weights, status)
            call check_status_code(error, status%code, HOLOSYM_SUCCESS, &
                "gauss_lobatto k = " // int_str(k))
            call check_monomials(error, nodes, weights, 2 * k - 3, "Lobatto k = " // int_str(k))
            if (allocated(error)) return
            deallocate (nodes, weights)
        end do
    end subroutine lobatto_exact_monomials

    !> tau^(2k-2) is NOT exact: with n = k-1 the error is
    !! -n^3 (n+1) ((n-1)!)^4 / ((2n+1) ((2n)!)^2) (the rule overestimates).
    subroutine lobatto_degree_2k_minus_2_error(error)
        type(test_error_t), allocatable, intent(out) :: error
        integer :: k, n
        real(wp), allocatable :: nodes(:), weights(:)
        real(wp) :: quad_error, expected
        do k = 2, max_points
            n = k - 1
            allocate (nodes(k), weights(k))
            call gauss_lobatto(nodes, weights)
            quad_error = 1.0_wp / (2 * n + 1) - sum(weights * nodes**(2 * n))
            expected = -real(n, wp)**3 * (n + 1) * factorial(n - 1)**4 &
                / ((2 * n + 1) * factorial(2 * n)**2)
            ! Errors below round-off cannot be measured (only in real64, for k >= 8).
            if (abs(expected) <= resolvable_error) then
                call check(error, precision(1.0_wp) < 30 .and. k > 7, &
                    "Lobatto k = " // int_str(k) // ": error formula below round-off")
                return
            end if
            call check(error, abs(quad_error) > resolvable_error, "Lobatto k = " // &
                int_str(k) // " integrates tau^(2k-2) exactly: the degree test could never fail")
            call check_close(error, quad_error, expected, 1.0e-6_wp, 0.0_wp, &
                "Lobatto k = " // int_str(k) // ", error on tau^(2k-2)")
            if (allocated(error)) return
            deallocate (nodes, weights)
        end do
    end subroutine lobatto_degree_2k_minus_2_error

    !> Weights positive and summing to 1, end weights 1/(k(k-1)), for k = 2..30.
    subroutine lobatto_weights(error)
        type(test_error_t), allocatable, intent(out) :: error
        integer :: k
        real(wp), allocatable :: nodes(:), weights(:)
        do k = 2, 30
            allocate (nodes(k), weights(k))
            call gauss_lobatto(nodes, weights)
            call check(error, all(weights > 0), "Lobatto k = " // int_str(k) // ": weight <= 0")
            call check_close(error, sum(weights), 1.0_wp, 0.0_wp, sum_tolerance, &
                "Lobatto k = " // int_str(k) // ": sum of weights")
            call check_close(error, weights(1), 1.0_wp / (k * (k - 1)), eps, 0.0_wp, &
                "Lobatto k = " // int_str(k) // ": end weight")
            if (allocated(error)) return
            deallocate (nodes, weights)
        end do
    end subroutine lobatto_weights

    !> Nodes strictly increasing in [0, 1] and symmetric about 1/2, for k = 2..30.
    subroutine lobatto_nodes(error)
        type(test_error_t), allocatable, intent(out) :: error
        integer :: k
        real(wp), allocatable :: nodes(:), weights(:)
        do k = 2, 30
            allocate (nodes(k), weights(k))
            call gauss_lobatto(nodes, weights)
            call check_rule_shape(error, nodes, weights, "Lobatto k = " // int_str(k))
            if (allocated(error)) return
            deallocate (nodes, weights)
        end do
    end subroutine lobatto_nodes

    !> The end nodes are exactly 0 and 1 (bit for bit), for k = 2..30.
    subroutine lobatto_ends(error)
        type(test_error_t), allocatable, intent(out) :: error
        integer :: k
        real(wp), allocatable :: nodes(:), weights(:)
        do k = 2, 30
            allocate (nodes(k), weights(k))
            call gauss_lobatto(nodes, weights)
            call check(error, nodes(1) == 0.0_wp, "Lobatto k = " // int_str(k) // &
                ": first node is not exactly 0")
            call check(error, nodes(k) == 1.0_wp, "Lobatto k = " // int_str(k) // &
                ": last node is not exactly 1")
            if (allocated(error)) return
            deallocate (nodes, weights)
        end do
    end subroutine lobatto_ends

    !> k = 2: trapezoid; k = 3: Simpson (0, 1/2, 1; 1/6, 4/6, 1/6);
    !! k = 4: 1/2 -+ sqrt(5)/10 inside, weights 1/12, 5/12, 5/12, 1/12.
    subroutine lobatto_closed_form(error)
        type(test_error_t), allocatable, intent(out) :: error
        real(wp) :: n2(2), w2(2), n3(3), w3(3), n4(4), w4(4)
        call gauss_lobatto(n2, w2)
        call check(error, all(n2 == [0.0_wp, 1.0_wp]), "k = 2 nodes")
        call check_close(error, w2(1), 0.5_wp, 0.0_wp, eps, "k = 2 weight 1")
        call check_close(error, w2(2), 0.5_wp, 0.0_wp, eps, "k = 2 weight 2")
        call gauss_lobatto(n3, w3)
        call check_close(error, n3(2), 0.5_wp, 0.0_wp, eps, "k = 3 node 2")
        call check_close(error, w3(1), 1.0_wp / 6, 0.0_wp, 2 * eps, "k = 3 weight 1")
        call check_close(error, w3(2), 4.0_wp / 6, 0.0_wp, 2 * eps, "k = 3 weight 2")
        call check_close(error, w3(3), 1.0_wp / 6, 0.0_wp, 2 * eps, "k = 3 weight 3")
        call gauss_lobatto(n4, w4)
        call check_close(error, n4(2), 0.5_wp - sqrt(5.0_wp) / 10, 0.0_wp, 2 * eps, "k = 4 node 2")
        call check_close(error, n4(3), 0.5_wp + sqrt(5.0_wp) / 10, 0.0_wp, 2 * eps, "k = 4 node 3")
        call check_close(error, w4(1), 1.0_wp / 12, 0.0_wp, 2 * eps, "k = 4 weight 1")
        call check_close(error, w4(2), 5.0_wp / 12, 0.0_wp, 2 * eps, "k = 4 weight 2")
        call check_close(error, w4(3), 5.0_wp / 12, 0.0_wp, 2 * eps, "k = 4 weight 3")
        call check_close(error, w4(4), 1.0_wp / 12, 0.0_wp, 2 * eps, "k = 4 weight 4")
    end subroutine lobatto_closed_form

    !> 30 points: exact on tau^k up to k = 57, shape checks, smooth integrand to round-off.
    subroutine lobatto_30_points(error)
        type(test_error_t), allocatable, intent(out) :: error
        real(wp) :: nodes(30), weights(30)
        type(holosym_status_t) :: status
        call gauss_lobatto(nodes, weights, status)
        call check_status_code(error, status%code, HOLOSYM_SUCCESS, "gauss_lobatto k = 30")
        call check_monomials(error, nodes, weights, 57, "Lobatto k = 30")
        call check_rule_shape(error, nodes, weights, "Lobatto k = 30")
        call check_close(error, sum(weights * exp(nodes)), exp(1.0_wp) - 1, 0.0_wp, &
            sum_tolerance, "Lobatto k = 30, integral of exp")
    end subroutine lobatto_30_points

    ! ------------------------------------------------------------------ invalid sizes

    !> G = 0 is an invalid argument; the message names the size.
    subroutine legendre_zero_points(error)
        type(test_error_t), allocatable, intent(out) :: error
        real(wp) :: nodes(0), weights(0)
        type(holosym_status_t) :: status
        call gauss_legendre(nodes, weights, status)
        call check_status_code(error, status%code, HOLOSYM_INVALID_ARGUMENT, "gauss_legendre G = 0")
        if (allocated(error)) return
        call check(error, allocated(status%message), "no message")
        if (allocated(error)) return
        call check(error, index(status%message, "got 0") > 0, &
            "message does not name the size: '" // status%message // "'")
    end subroutine legendre_zero_points

    !> size(weights) /= size(nodes) is a size mismatch (both too short and too long).
    subroutine legendre_size_mismatch(error)
        type(test_error_t), allocatable, intent(out) :: error
        real(wp) :: nodes(4), short(3), long(5)
        type(holosym_status_t) :: status
        call gauss_legendre(nodes, short, status)
        call check_status_code(error, status%code, HOLOSYM_SIZE_MISMATCH, "4 nodes, 3 weights")
        if (allocated(error)) return
        call check(error, index(status%message, "3") > 0 .and. index(status%message, "4") > 0, &
            "message does not name the sizes: '" // status%message // "'")
        call gauss_legendre(nodes, long, status)
        call check_status_code(error, status%code, HOLOSYM_SIZE_MISMATCH, "4 nodes, 5 weights")
    end subroutine legendre_size_mismatch

    !> k = 0 and k = 1 are invalid for Lobatto (both ends are nodes).
    subroutine lobatto_too_few_points(error)
        type(test_error_t), allocatable, intent(out) :: error
        real(wp) :: n0(0), w0(0), n1(1), w1(1)
        type(holosym_status_t) :: status
        call gauss_lobatto(n0, w0, status)
        call check_status_code(error, status%code, HOLOSYM_INVALID_ARGUMENT, "gauss_lobatto k = 0")
        call gauss_lobatto(n1, w1, status)
        call check_status_code(error, status%code, HOLOSYM_INVALID_ARGUMENT, "gauss_lobatto k = 1")
        if (allocated(error)) return
        call check(error, index(status%message, "got 1") > 0, &
            "message does not name the size: '" // status%message // "'")
    end subroutine lobatto_too_few_points

    !> size(weights) /= size(nodes) is a size mismatch for Lobatto too.
    subroutine lobatto_size_mismatch(error)
        type(test_error_t), allocatable, intent(out) :: error
        real(wp) :: nodes(3), short(2), long(4)
        type(holosym_status_t) :: status
        call gauss_lobatto(nodes, short, status)
        call check_status_code(error, status%code, HOLOSYM_SIZE_MISMATCH, "3 nodes, 2 weights")
        call gauss_lobatto(nodes, long, status)
        call check_status_code(error, status%code, HOLOSYM_SIZE_MISMATCH, "3 nodes, 4 weights")
        if (allocated(error)) return
        call check(error, len(status%message) > 0, "empty message")
    end subroutine lobatto_size_mismatch

end module test_quadrature
