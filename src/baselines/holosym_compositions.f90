!> Symmetric compositions of a symmetric second-order method (Hairer, Lubich, Wanner,
!! "Geometric Numerical Integration", sections II.4 and V.3; the methods of Hairer's
!! GNI_COMP): Psi_h = Phi_(gamma_s h) o ... o Phi_(gamma_1 h), gamma_(s+1-k) = gamma_k.
!!
!! Families (order: stages):
!! - 'triple-jump'  (2..10: 3^(p/2-1)) and 'suzuki' (2..10: 5^(p/2-1)): closed forms,
!!   exact to working precision.
!! - 'yoshida' (6: 7), 'kahan-li' (6: 9, 8: 17), 'suzuki-umeno' (8: 15),
!!   'hlw' (Hairer-Lubich-Wanner, 10: 33), 'sofroniou-spaletta' (10: 33): published with
!!   26-32 digits, which would leave an error floor near 1e-26 in real128. Their
!!   coefficients are recomputed to working precision by Newton's method on the order
!!   conditions, started from the published digits (minimum-norm corrections where the
!!   family has free parameters), so the result is an exact solution next to the
!!   published one.
!!
!! Order conditions. Write the basic method as Phi_t = exp(t Y1 + t^3 Y3 + t^5 Y5 + ...)
!! with free non-commuting Y_i (odd powers only: the method is symmetric). The composition
!! is a product of exponentials in the free algebra of the Y_i (Y_i of weight i), and it
!! has order p when it agrees with exp(h Y1) in every word of weight <= p. It is a
!! group-like element, so it is determined by its coefficients on Lyndon words (Radford),
!! and a symmetric composition has only odd-weight terms in its logarithm. Hence order p
!! holds exactly when the coefficient of every Lyndon word of odd weight < p in the
!! composition equals its coefficient in exp(Y1) (1 for the word 'Y1', 0 for the others):
!! 1, 2, 4, 8, 16 conditions for orders 2, 4, 6, 8, 10 (the counts of the book).
!! The coefficient of a word a_1 ... a_r in the product is a sum over the ways of
!! splitting the word into consecutive pieces, piece k from factor k, each piece u
!! contributing gamma_k^(weight u) / (letters of u)!; a short recursion over the factors
!! computes it with its derivatives.
module holosym_compositions
    use holosym_kinds, only: wp
    use holosym_status_codes, only: holosym_status_t, set_status, int_str, real_str, &
        HOLOSYM_SUCCESS, HOLOSYM_INVALID_ORDER, HOLOSYM_INVALID_ARGUMENT, &
        HOLOSYM_NEWTON_NOT_CONVERGED
    use holosym_linalg, only: lu_factor, lu_solve
    implicit none
    private

    public :: composition_coefficients, composition_order_residuals, &
              published_coefficients, composition_orders

    !> Largest composition order.
    integer, parameter, public :: composition_max_order = 10
    !> The composition families, as `composition_coefficients` names them.
    character(len=*), parameter, public :: composition_families(7) = [character(len=18) :: &
        "triple-jump", "suzuki", "yoshida", "kahan-li", "suzuki-umeno", "hlw", &
        "sofroniou-spaletta"]

    !> Largest weight of a word in the order conditions (order 10).
    integer, parameter :: max_weight = composition_max_order - 1
    !> Newton iterations on the order conditions.
    integer, parameter :: max_newton = 12

contains

    !> Orders a family provides (0 where it has none), e.g. [6, 8] for 'kahan-li'.
    pure function composition_orders(family) result(orders)
        character(len=*), intent(in) :: family !! a name of `composition_families`
        integer, allocatable :: orders(:)      !! its orders, empty for an unknown name
        select case (family)
        case ("triple-jump", "suzuki")
            orders = [2, 4, 6, 8, 10]
        case ("yoshida")
            orders = [6]
        case ("kahan-li")
            orders = [6, 8]
        case ("suzuki-umeno")
            orders = [8]
        case ("hlw", "sofroniou-spaletta")
            orders = [10]
        case default
            allocate (orders(0))
        end select
    end function composition_orders

    !> The first half gamma_1 .. gamma_((s+1)/2) of a published composition as printed
    !! (GNI_COMP's tables; Hairer, Lubich, Wanner, section V.3). Empty for the closed-form
    !! families and for orders a family lacks.
    pure function published_coefficients(order, family) result(half)
        integer, intent(in) :: order          !! composition order
        character(len=*), intent(in) :: family !! family name
        real(wp), allocatable :: half(:)      !! gamma_1 .. gamma_((s+1)/2)
        allocate (half(0))
        select case (family)
        case ("yoshida")  ! Yoshida (1990), order 6, 7 stages
            if (order == 6) half = [0.78451361047755726381949763_wp, &
                0.23557321335935813368479318_wp, -1.17767998417887100694641568_wp, &
                1.31518632068391121888424973_wp]
        case ("kahan-li")  ! Kahan and Li (1997)
            if (order == 6) half = [0.39215846226558135393725811_wp, &  ! 9 stages
                0.33260288849639382848984234_wp, -0.70624607359230088534941023_wp, &
                0.08221272729243641010472095_wp, 0.79854399107577858563517766_wp]
            if (order == 8) half = [0.13020248308889008087881763_wp, &  ! 17 stages
                0.56116298177510838456196441_wp, -0.38947496264484728640807860_wp, &
                0.15884190655515560089621075_wp, -0.39590389413323757733623154_wp, &
                0.18453964097831570709183254_wp, 0.25837438768632204729397911_wp, &
                0.29501172360931029887096624_wp, -0.60550853383003451169892108_wp]
        case ("suzuki-umeno")  ! Suzuki and Umeno (1993), order 8, 15 stages
            if (order == 8) half = [0.74167036435061295344822780_wp, &
                -0.40910082580003159399730010_wp, 0.19075471029623837995387626_wp, &
                -0.57386247111608226665638773_wp, 0.29906418130365592384446354_wp, &
                0.33462491824529818378495798_wp, 0.31529309239676659663205666_wp, &
                -0.79688793935291635401978884_wp]
        case ("hlw")  ! Hairer, Lubich and Wanner (2002), order 10, 33 stages
            if (order == 10) half = [0.09040619368607278492161150_wp, &
                0.53591815953030120213784983_wp, 0.35123257547493978187517736_wp, &
                -0.31116802097815835426086544_wp, -0.52556314194263510431065549_wp, &
                0.14447909410225247647345695_wp, 0.02983588609748235818064083_wp, &
                0.17786179923739805133592238_wp, 0.09826906939341637652532377_wp, &
                0.46179986210411860873242126_wp, -0.33377845599881851314531820_wp, &
                0.07095684836524793621031152_wp, 0.23666960070126868771909819_wp, &
                -0.49725977950660985445028388_wp, -0.30399616617237257346546356_wp, &
                0.05246957188100069574521612_wp, 0.44373380805019087955111365_wp]
        case ("sofroniou-spaletta")  ! Sofroniou and Spaletta (2003), order 10, 33 stages
            if (order == 10) half = [0.070711261586085399079302771810203_wp, &
                0.090342080937267568345577914389234_wp, &
                0.14103133297152486103524322594476_wp, &
                0.40206004554029767537357060971803_wp, &
                -0.30239722849131075165735249848238_wp, &
                -0.22462355658241460137093154363351_wp, &
                0.061496988956063121940380707068411_wp, &
                0.11346847775740802675296685287062_wp, &
                0.23654672241381781124636015203490_wp, &
                0.27211409645898977643699556260890_wp, &
                0.076129418470277234386530906651024_wp, &
                -0.18543093454238185309165565783301_wp, &
                -0.46495110925607623804616342747217_wp, &
                0.10423014962104084592532590279051_wp, &
                0.13621181452383232935841998116651_wp, &
                -0.27010275720513252644976102610064_wp, &
                0.48632639368142264147037913293721_wp]
        end select
    end function published_coefficients

    !> Substep fractions of the symmetric composition of order `order` of family `family`
    !! (see the module header), summing to 1. Codes: HOLOSYM_INVALID_ORDER (an order the
    !! family lacks), HOLOSYM_INVALID_ARGUMENT (unknown family), HOLOSYM_NEWTON_NOT_CONVERGED
    !! (the order conditions could not be solved to working precision; not expected).
    subroutine composition_coefficients(order, family, gammas, status)
        integer, intent(in) :: order          !! 2, 4, 6, 8 or 10 (as the family provides)
        character(len=*), intent(in) :: family !! one of `composition_families`
        real(wp), allocatable, intent(out) :: gammas(:) !! fractions of h, summing to 1
        type(holosym_status_t), intent(out), optional :: status !! outcome
        type(holosym_status_t) :: local
        real(wp), allocatable :: half(:)
        real(wp) :: g1, g2
        integer :: p, s, k
        integer, allocatable :: orders(:)
        orders = composition_orders(family)
        if (size(orders) == 0) then
            call set_status(status, HOLOSYM_INVALID_ARGUMENT, "composition must be one of " &
                // "triple-jump, suzuki, yoshida, kahan-li, suzuki-umeno, hlw, " // &
                "sofroniou-spaletta; got '" // family // "'")
            return
        end if
        if (.not. any(orders == order)) then
            call set_status(status, HOLOSYM_INVALID_ORDER, "composition '" // family // &
                "' has orders " // order_list(orders) // "; got " // int_str(order))
            return
        end if
        if (family == "triple-jump" .or. family == "suzuki") then
            gammas = [1.0_wp]
            do p = 2, order - 2, 2
                if (family == "triple-jump") then
                    g1 = 1 / (2 - 2.0_wp**(1.0_wp / (p + 1)))
                    g2 = 1 - 2 * g1
                    gammas = [g1 * gammas, g2 * gammas, g1 * gammas]
                else
                    g1 = 1 / (4 - 4.0_wp**(1.0_wp / (p + 1)))
                    g2 = 1 - 4 * g1
                    gammas = [g1 * gammas, g1 * gammas, g2 * gammas, g1 * gammas, g1 * gammas]
                end if
            end do
            call set_status(status, HOLOSYM_SUCCESS, "")
            return
        end if
        half = published_coefficients(order, family)
        call refine(half, order, local)
        if (.not. local%ok()) then
            call set_status(status, local%code, "composition '" // family // "' order " // &
                int_str(order) // ": " // local%message)
            return
        end if
        s = 2 * size(half) - 1
        allocate (gammas(s))
        do k = 1, s
            gammas(k) = half(min(k, s + 1 - k))
        end do
        call set_status(status, HOLOSYM_SUCCESS, "")
    contains
        pure function order_list(values) result(text)
            integer, intent(in) :: values(:)
            character(len=:), allocatable :: text
            integer :: i
            text = ""
            do i = 1, size(values)
                if (i > 1) text = text // ", "
                text = text // int_str(values(i))
            end do
        end function order_list
    end subroutine composition_coefficients

    !> Residuals of the order conditions of order `order` (even, 2..10) for the symmetric
    !! composition `gammas` (all s fractions; the first half is read, the second is taken
    !! as its mirror image): coefficient in the composition minus coefficient in exp(Y1),
    !! one per Lyndon word of odd weight < order (see the module header).
    pure function composition_order_residuals(gammas, order) result(residuals)
        real(wp), intent(in) :: gammas(:) !! gamma_1 .. gamma_s
        integer, intent(in) :: order      !! even order 2 .. 10
        real(wp), allocatable :: residuals(:) !! one per condition
        real(wp), allocatable :: jacobian(:, :)
        call conditions(gammas(1:(size(gammas) + 1) / 2), size(gammas), order, residuals, &
                        jacobian)
    end function composition_order_residuals

    !> Newton's method on the order conditions from the published half `half`.
    subroutine refine(half, order, status)
        real(wp), intent(inout) :: half(:)
        integer, intent(in) :: order
        type(holosym_status_t), intent(out) :: status
        real(wp), allocatable :: residuals(:), jacobian(:, :), normal(:, :), rhs(:, :)
        real(wp) :: size_now, size_before
        integer, allocatable :: pivots(:)
        integer :: iteration, info, s
        s = 2 * size(half) - 1
        size_before = huge(1.0_wp)
        do iteration = 1, max_newton
            call conditions(half, s, order, residuals, jacobian)
            size_now = maxval(abs(residuals))
            if (size_now <= 4 * epsilon(1.0_wp)) exit
            if (iteration > 2 .and. size_now >= size_before / 2) exit  ! round-off reached
            size_before = size_now
            ! Minimum-norm correction: J^T (J J^T)^-1 r (J is conditions x unknowns).
            normal = matmul(jacobian, transpose(jacobian))
            rhs = reshape(residuals, [size(residuals), 1])
            if (allocated(pivots)) deallocate (pivots)
            allocate (pivots(size(residuals)))
            call lu_factor(normal, pivots, info)
            if (info /= 0) then
                status%code = HOLOSYM_NEWTON_NOT_CONVERGED
                status%message = "singular order-condition Jacobian"
                return
            end if
            call lu_solve(normal, pivots, rhs)
            half = half - matmul(transpose(jacobian), rhs(:, 1))
        end do
        call conditions(half, s, order, residuals, jacobian)
        if (maxval(abs(residuals)) > 64 * epsilon(1.0_wp)) then
            status%code = HOLOSYM_NEWTON_NOT_CONVERGED
            status%message = "order conditions solved only to " // &
                real_str(maxval(abs(residuals)))
            return
        end if
        status%code = HOLOSYM_SUCCESS
        status%message = ""
    end subroutine refine

    !> The order conditions of a symmetric s-stage composition given by its first half
    !! (unknowns), with their derivatives with respect to the unknowns.
    pure subroutine conditions(half, s, order, residuals, jacobian)
        real(wp), intent(in) :: half(:)   !! gamma_1 .. gamma_((s+1)/2)
        integer, intent(in) :: s          !! stages
        integer, intent(in) :: order      !! even order
        real(wp), allocatable, intent(out) :: residuals(:), jacobian(:, :)
        integer :: words(max_weight, 64), lengths(64), count, w
        real(wp) :: value, gradient(size(half))
        call lyndon_words(order - 1, words, lengths, count)
        allocate (residuals(count), jacobian(count, size(half)))
        do w = 1, count
            call word_coefficient(half, s, words(1:lengths(w), w), value, gradient)
            ! exp(Y1) has coefficient 1 on the Lyndon word 'Y1' and 0 on the others.
            if (lengths(w) == 1 .and. words(1, w) == 1) value = value - 1
            residuals(w) = value
            jacobian(w, :) = gradient
        end do
    end subroutine conditions

    !> Coefficient of the word `letters` (weights of its letters) in the composition, and
    !! its gradient with respect to the first half of the gammas.
    pure subroutine word_coefficient(half, s, letters, value, gradient)
        real(wp), intent(in) :: half(:)
        integer, intent(in) :: s, letters(:)
        real(wp), intent(out) :: value, gradient(:)
        ! table(j): coefficient of the first j letters in the product of the factors so far.
        real(wp) :: table(0:size(letters)), table_gradient(size(half), 0:size(letters))
        real(wp) :: new_table(0:size(letters)), new_gradient(size(half), 0:size(letters))
        real(wp) :: gamma, factor, derivative, inverse_factorial(0:size(letters))
        integer :: r, k, i, j, weight, unknown
        r = size(letters)
        inverse_factorial(0) = 1
        do j = 1, r
            inverse_factorial(j) = inverse_factorial(j - 1) / j
        end do
        table = 0
        table(0) = 1
        table_gradient = 0
        do k = 1, s
            unknown = min(k, s + 1 - k)
            gamma = half(unknown)
            new_table = 0
            new_gradient = 0
            do j = 0, r
                do i = 0, j
                    ! Letters i+1 .. j come from factor k: gamma^weight / (j - i)!.
                    weight = sum(letters(i + 1:j))
                    factor = gamma**weight * inverse_factorial(j - i)
                    new_table(j) = new_table(j) + table(i) * factor
                    new_gradient(:, j) = new_gradient(:, j) + table_gradient(:, i) * factor
                    if (weight > 0) then
                        derivative = weight * gamma**(weight - 1) * inverse_factorial(j - i)
                        new_gradient(unknown, j) = new_gradient(unknown, j) + &
                            table(i) * derivative
                    end if
                end do
            end do
            table = new_table
            table_gradient = new_gradient
        end do
        value = table(r)
        gradient = table_gradient(:, r)
    end subroutine word_coefficient

    !> The Lyndon words over the letters 1 < 3 < 5 < 7 < 9 (a letter's weight is its
    !! value) of odd weight <= `max_total`, as columns of `words`.
    pure subroutine lyndon_words(max_total, words, lengths, count)
        integer, intent(in) :: max_total
        integer, intent(out) :: words(:, :), lengths(:), count
        integer :: word(max_weight)
        count = 0
        words = 0
        lengths = 0
        call extend(max_total, word, 0, 0, words, lengths, count)
    end subroutine lyndon_words

    !> Add the Lyndon words that start with word(1:length) (weight `total`).
    pure recursive subroutine extend(max_total, word, length, total, words, lengths, count)
        integer, intent(in) :: max_total, length, total
        integer, intent(inout) :: word(:), words(:, :), lengths(:), count
        integer :: letter
        if (length > 0 .and. mod(total, 2) == 1) then
            if (is_lyndon(word(1:length))) then
                count = count + 1
                words(1:length, count) = word(1:length)
                lengths(count) = length
            end if
        end if
        do letter = 1, max_total - total, 2
            word(length + 1) = letter
            call extend(max_total, word, length + 1, total + letter, words, lengths, count)
        end do
    end subroutine extend

    !> A word is Lyndon when it is lexicographically smaller than each of its proper
    !! suffixes.
    pure logical function is_lyndon(word)
        integer, intent(in) :: word(:)
        integer :: start
        is_lyndon = .true.
        do start = 2, size(word)
            if (.not. lexically_less(word, word(start:))) then
                is_lyndon = .false.
                return
            end if
        end do
    end function is_lyndon

    !> a < b in lexicographic order (a proper prefix is smaller).
    pure logical function lexically_less(a, b)
        integer, intent(in) :: a(:), b(:)
        integer :: i
        do i = 1, min(size(a), size(b))
            if (a(i) /= b(i)) then
                lexically_less = a(i) < b(i)
                return
            end if
        end do
        lexically_less = size(a) < size(b)
    end function lexically_less

end module holosym_compositions
