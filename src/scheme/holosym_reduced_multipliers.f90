!> category: internal module (use holosym)
!! The reduced equations' iteration matrix without curvature, solved through the
!! multipliers: the fixed-point iteration of the reduced step (forces frozen at the
!! iterate, constraint forces from a small solve in the multipliers alone).
!!
!! With the gradient of U and Phi frozen, the rows D_0..D_(M-1) of the reduced equations
!! (`holosym_reduced_scheme`) are linear in the increments z_1..z_M through one constant
!! M x M matrix L per coordinate, L(i, k) = S(i, k) (row 0: minus the sum of rows 1..M, as
!! the residual forms D_0), scaled by m_c / h. Leaving out the second derivatives of U and
!! phi, a correction (dz, dmu) for a residual r = (r_D, r_phi, r_v) solves
!!     (m_c/h) sum_k L(i, k) dz_k[c] - wl_i (Phi_i^T dmu_i)[c] = r_D,i[c]   (i = 0..M-1)
!!     Phi_k dz_k = r_phi,k                                               (k = 1..M)
!!     Phi_M M^-1 ((m/h) sum_k L(M, k) dz_k - wl_M Phi_M^T dmu_M) + K dz_M = r_v,
!! so dz = y + (h/m_c) L^-1 (wl Phi^T dmu) with y = (h/m_c) L^-1 r_D, the multipliers
!! dmu_0..dmu_(M-1) from the M m x M m system
!!     sum_i h L^-1(k, i) wl_i Phi_k M^-1 Phi_i^T dmu_i = r_phi,k - Phi_k y_k,
!! and dmu_M from the m x m system wl_M Phi_M M^-1 Phi_M^T dmu_M = Phi_M (1/h) sum_k
!! L(M, k) dz_k + K dz_M - r_v. K = d(Phi(q) v)/dq at q_M (v the end velocity) is kept:
!! it is of order h |v| / |q|, not h^2, relative to the other terms of that row, and
!! costs one difference of Phi. Only first derivatives enter: forming and factoring it costs a few
!! products of Phi per node pair, against the Newton matrix's second derivatives and its
!! (M n + (M + 1) m)-order factorization. The multiplier system couples two constraints
!! when they share a coordinate; in the layout's constraint order it is banded when the
!! Newton matrix is (a chain: a band of about 2 M). Its contraction as an iteration is
!! that of the left-out curvature, about h^2 |U''| / m and h^2 |lambda phi''| / m.
module holosym_reduced_multipliers
    use holosym_kinds, only: wp, dp
    use holosym_linalg, only: lu_factor, lu_solve
    use holosym_factors, only: real64_factors_t
    use holosym_reduced_layout, only: reduced_layout_t
    implicit none
    private

    public :: multiplier_solve_t

    !> The curvature-free iteration matrix of one (M, system), factored for one step.
    type :: multiplier_solve_t
        integer :: order_m = 0, n = 0, m = 0
        real(dp), allocatable :: linv(:, :)   !! L^-1, (1:M, 0:M-1)
        real(dp), allocatable :: last_row(:)  !! L(M, k), k = 1..M
        real(dp), allocatable :: wl(:)        !! Lobatto weights (0:M)
        real(dp), allocatable :: inv_mass(:)  !! 1 / m_c
        real(dp) :: h = 0
        !> Pairs (l1, l2) of constraints sharing a coordinate, and the terms
        !! Phi(l1, c) Phi(l2, c) / m_c of their products: entries term_e1, term_e2 of Phi's
        !! pattern in column term_c, for pair term_pair.
        integer, allocatable :: pair_l1(:), pair_l2(:), pair_slot(:)
        integer, allocatable :: term_pair(:), term_e1(:), term_e2(:), term_c(:)
        !> Position of each constraint in the band order (the layout's constraint order).
        integer, allocatable :: band_position(:)
        !> Compressed rows of the multiplier system (M m) and of the m x m end system.
        integer, allocatable :: a_start(:), a_col(:), g_start(:), g_col(:)
        real(dp), allocatable :: a_values(:), g_values(:)
        type(real64_factors_t) :: multipliers, ends
        !> Phi at the nodes the factors were formed with (nnz, 0:M), and K on Phi's pattern.
        real(dp), allocatable :: pv(:, :), kv(:)
        logical :: factored = .false.
        !> L is singular (G too small for the scheme): no iteration matrix.
        logical :: singular = .true.
        ! Workspace.
        real(dp), allocatable :: y(:, :), dz(:, :), t(:, :), dmu(:, :), rhs(:), pair_value(:)
        real(dp), allocatable :: w(:), end_rhs(:)  !! of `end_multipliers`
    contains
        !> Set up for a layout and the scheme's tables.
        procedure :: init => multipliers_init
        !> Form and factor the matrix for Phi at the nodes.
        procedure :: factor => multipliers_factor
        !> Solve for the correction of a residual, in place.
        procedure :: solve => multipliers_solve
    end type multiplier_solve_t

contains

    !> Set up for the layout `lay` (sizes, Phi's pattern, constraint order), the tables
    !! `st` (S(i, k) at (k, i), k = 1..M, i = 0..M) and `wl` (Lobatto weights) and the
    !! masses. L is singular when G is too small for (M, N) (the Newton matrix is then
    !! singular too): `factor` then always reports a singular matrix.
    subroutine multipliers_init(self, lay, st, wl, mass)
        class(multiplier_solve_t), intent(out) :: self
        type(reduced_layout_t), intent(in) :: lay
        real(wp), intent(in) :: st(:, 0:)   !! (M, 0:M)
        real(wp), intent(in) :: wl(0:)      !! (0:M)
        real(wp), intent(in) :: mass(:)     !! (n)
        real(wp), allocatable :: l(:, :), identity(:, :)
        integer, allocatable :: pivots(:)
        integer :: mm, i, k, info
        mm = lay%order_m
        self%order_m = mm
        self%n = lay%n
        self%m = lay%m
        ! L(i, k) for rows i = 0..M-1 (stored at (i + 1, k)), inverted in working precision.
        allocate (l(mm, mm), identity(mm, mm), pivots(mm))
        do k = 1, mm
            l(1, k) = -sum(st(k, 1:mm))
            do i = 1, mm - 1
                l(i + 1, k) = st(k, i)
            end do
        end do
        identity = 0
        do k = 1, mm
            identity(k, k) = 1
        end do
        call lu_factor(l, pivots, info)
        self%singular = info /= 0
        if (self%singular) return
        call lu_solve(l, pivots, identity)
        allocate (self%linv(mm, 0:mm - 1), self%last_row(mm))
        self%linv = real(identity, dp)
        self%last_row = real(st(:, mm), dp)
        allocate (self%wl(0:mm))
        self%wl = real(wl(0:mm), dp)
        self%inv_mass = real(1 / mass, dp)
        allocate (self%y(self%n, mm), self%dz(self%n, mm), self%t(self%n, 0:mm), &
                  self%dmu(self%m, 0:mm), self%rhs(self%m * mm), self%pv(size(lay%phi_rows), 0:mm), &
                  self%kv(size(lay%phi_rows)), self%w(self%n), self%end_rhs(self%m))
        self%pv = 0
        self%kv = 0
        if (self%m > 0) call build_patterns(self, lay)
    end subroutine multipliers_init

    !> The constraint pairs sharing a coordinate, their product terms, and the compressed
    !! rows of both systems in the band order. Work linear in the entries of Phi for a
    !! bounded number of constraints per coordinate.
    subroutine build_patterns(self, lay)
        type(multiplier_solve_t), intent(inout) :: self
        type(reduced_layout_t), intent(in) :: lay
        integer, allocatable :: count(:), order(:), head(:), next(:)
        integer :: c, a, b, e1, e2, p, q, l1, l2, pairs, terms, mm, k, i, band, pos
        mm = self%order_m
        self%band_position = lay%constraint_order
        terms = 0
        do c = 1, self%n
            terms = terms + (lay%col_entry_start(c + 1) - lay%col_entry_start(c))**2
        end do
        allocate (self%term_pair(terms), self%term_e1(terms), self%term_e2(terms), &
                  self%term_c(terms), self%pair_l1(terms), self%pair_l2(terms), next(terms))
        ! Pairs and terms: every pair of Phi's entries in one column; the pairs of each
        ! constraint l1 in a linked list (head, next).
        allocate (count(self%m), head(self%m))
        count = 0
        head = 0
        pairs = 0
        terms = 0
        do c = 1, self%n
            do a = lay%col_entry_start(c), lay%col_entry_start(c + 1) - 1
                do b = lay%col_entry_start(c), lay%col_entry_start(c + 1) - 1
                    e1 = lay%col_entry(a)
                    e2 = lay%col_entry(b)
                    l1 = lay%phi_rows(e1)
                    l2 = lay%phi_rows(e2)
                    p = head(l1)
                    do while (p /= 0)
                        if (self%pair_l2(p) == l2) exit
                        p = next(p)
                    end do
                    if (p == 0) then
                        pairs = pairs + 1
                        self%pair_l1(pairs) = l1
                        self%pair_l2(pairs) = l2
                        next(pairs) = head(l1)
                        head(l1) = pairs
                        count(l1) = count(l1) + 1
                        p = pairs
                    end if
                    terms = terms + 1
                    self%term_pair(terms) = p
                    self%term_e1(terms) = e1
                    self%term_e2(terms) = e2
                    self%term_c(terms) = c
                end do
            end do
        end do
        self%pair_l1 = self%pair_l1(1:pairs)
        self%pair_l2 = self%pair_l2(1:pairs)
        ! Each pair's slot among the pairs of its constraint l1, in the band order of l2.
        allocate (self%pair_slot(pairs))
        do p = 1, pairs
            pos = 1
            q = head(self%pair_l1(p))
            do while (q /= 0)
                if (self%band_position(self%pair_l2(q)) < self%band_position(self%pair_l2(p))) &
                    pos = pos + 1
                q = next(q)
            end do
            self%pair_slot(p) = pos
        end do
        ! Row (l, k) of the multiplier system is (band_position(l) - 1) M + k.
        allocate (self%a_start(self%m * mm + 1), self%g_start(self%m + 1), order(self%m))
        do l1 = 1, self%m
            order(self%band_position(l1)) = l1
        end do
        self%a_start(1) = 1
        self%g_start(1) = 1
        do pos = 1, self%m
            do k = 1, mm
                a = (pos - 1) * mm + k
                self%a_start(a + 1) = self%a_start(a) + count(order(pos)) * mm
            end do
            self%g_start(pos + 1) = self%g_start(pos) + count(order(pos))
        end do
        allocate (self%a_col(self%a_start(self%m * mm + 1) - 1), &
                  self%g_col(self%g_start(self%m + 1) - 1))
        band = 0
        do p = 1, pairs
            l1 = self%pair_l1(p)
            l2 = self%pair_l2(p)
            band = max(band, abs(self%band_position(l1) - self%band_position(l2)))
            self%g_col(self%g_start(self%band_position(l1)) + self%pair_slot(p) - 1) = &
                self%band_position(l2)
            do k = 1, mm
                do i = 0, mm - 1
                    self%a_col(a_entry(self, p, k, i)) = (self%band_position(l2) - 1) * mm + i + 1
                end do
            end do
        end do
        allocate (self%a_values(size(self%a_col)), self%g_values(size(self%g_col)), &
                  self%pair_value(pairs))
        call self%ends%setup(self%m, min(band, self%m - 1), min(band, self%m - 1))
        band = min(band * mm + mm - 1, self%m * mm - 1)
        call self%multipliers%setup(self%m * mm, band, band)
    end subroutine build_patterns

    !> Entry of the multiplier system for pair p, row node k, column node i.
    pure integer function a_entry(self, p, k, i) result(e)
        type(multiplier_solve_t), intent(in) :: self
        integer, intent(in) :: p, k, i
        integer :: r
        r = (self%band_position(self%pair_l1(p)) - 1) * self%order_m + k
        e = self%a_start(r) + (self%pair_slot(p) - 1) * self%order_m + i
    end function a_entry

    !> Form and factor both systems for step size h, the values `pv` of Phi at nodes
    !! 0..M (nnz, 0:M) and K on Phi's pattern (`kv`). `info` is 0, or nonzero when either
    !! is singular (dependent constraints at a node: the Newton matrix then says where).
    subroutine multipliers_factor(self, h, pv, kv, info)
        class(multiplier_solve_t), intent(inout) :: self
        real(wp), intent(in) :: h
        real(dp), intent(in) :: pv(:, 0:)
        real(dp), intent(in) :: kv(:)
        integer, intent(out) :: info
        integer :: mm, k, i, p
        info = 0
        self%factored = .false.
        if (self%singular) then
            info = 1
            return
        end if
        self%h = real(h, dp)
        self%pv = pv
        self%kv = kv
        if (self%m == 0) then
            self%factored = .true.
            return
        end if
        mm = self%order_m
        do k = 1, mm
            do i = 0, mm - 1
                call pair_products(self, k, i)
                do p = 1, size(self%pair_value)
                    self%a_values(a_entry(self, p, k, i)) = self%h * self%linv(k, i) * &
                        self%wl(i) * self%pair_value(p)
                end do
            end do
        end do
        call self%multipliers%factor(self%a_start, self%a_col, self%a_values, info)
        if (info /= 0) return
        call pair_products(self, mm, mm)
        do p = 1, size(self%pair_value)
            self%g_values(self%g_start(self%band_position(self%pair_l1(p))) + &
                          self%pair_slot(p) - 1) = self%wl(mm) * self%pair_value(p)
        end do
        call self%ends%factor(self%g_start, self%g_col, self%g_values, info)
        if (info /= 0) return
        self%factored = .true.
    end subroutine multipliers_factor

    !> pair_value(p) = (Phi_k M^-1 Phi_i^T)(l1, l2) of each pair.
    pure subroutine pair_products(self, k, i)
        type(multiplier_solve_t), intent(inout) :: self
        integer, intent(in) :: k, i
        integer :: t
        self%pair_value = 0
        do t = 1, size(self%term_pair)
            self%pair_value(self%term_pair(t)) = self%pair_value(self%term_pair(t)) + &
                self%pv(self%term_e1(t), k) * self%pv(self%term_e2(t), i) * &
                self%inv_mass(self%term_c(t))
        end do
    end subroutine pair_products

    !> Replace the residual r (layout order, real64) by the correction P^-1 r of the
    !! curvature-free matrix P; `lay` the layout, `phi_rows`, `phi_cols` Phi's pattern.
    subroutine multipliers_solve(self, lay, r)
        class(multiplier_solve_t), intent(inout) :: self
        type(reduced_layout_t), intent(in) :: lay
        real(dp), intent(inout) :: r(:)
        integer :: mm, c, k, i, e, l, pos
        real(dp) :: total
        mm = self%order_m
        ! y = (h / m_c) L^-1 r_D.
        do c = 1, self%n
            do k = 1, mm
                total = 0
                do i = 0, mm - 1
                    total = total + self%linv(k, i) * r(lay%d_row(c, i))
                end do
                self%y(c, k) = self%h * self%inv_mass(c) * total
            end do
        end do
        self%dz = self%y
        self%dmu = 0
        if (self%m > 0) then
            ! The multipliers of nodes 0..M-1: r_phi,k - Phi_k y_k in band order.
            do l = 1, self%m
                pos = self%band_position(l)
                do k = 1, mm
                    self%rhs((pos - 1) * mm + k) = r(lay%phi_row(l, k))
                end do
            end do
            do e = 1, size(lay%phi_rows)
                pos = self%band_position(lay%phi_rows(e))
                do k = 1, mm
                    self%rhs((pos - 1) * mm + k) = self%rhs((pos - 1) * mm + k) - &
                        self%pv(e, k) * self%y(lay%phi_cols(e), k)
                end do
            end do
            call self%multipliers%solve(self%rhs)
            do l = 1, self%m
                pos = self%band_position(l)
                do i = 0, mm - 1
                    self%dmu(l, i) = self%rhs((pos - 1) * mm + i + 1)
                end do
            end do
            ! dz = y + (h / m_c) L^-1 (wl Phi^T dmu).
            self%t = 0
            do i = 0, mm - 1
                do e = 1, size(lay%phi_rows)
                    self%t(lay%phi_cols(e), i) = self%t(lay%phi_cols(e), i) + &
                        self%wl(i) * self%pv(e, i) * self%dmu(lay%phi_rows(e), i)
                end do
            end do
            do c = 1, self%n
                do k = 1, mm
                    total = 0
                    do i = 0, mm - 1
                        total = total + self%linv(k, i) * self%t(c, i)
                    end do
                    self%dz(c, k) = self%dz(c, k) + self%h * self%inv_mass(c) * total
                end do
            end do
            call end_multipliers(self, lay, r)
        end if
        ! Element by element: a vector subscript on the left would allocate a temporary.
        do k = 1, mm
            do c = 1, self%n
                r(lay%z_col(c, k)) = self%dz(c, k)
            end do
        end do
        do i = 0, mm
            do l = 1, self%m
                r(lay%mu_col(l, i)) = self%dmu(l, i)
            end do
        end do
    end subroutine multipliers_solve

    !> dmu_M from the end system: wl_M Phi_M M^-1 Phi_M^T dmu_M = Phi_M w + K dz_M - r_v
    !! with w = (1/h) sum_k L(M, k) dz_k.
    subroutine end_multipliers(self, lay, r)
        type(multiplier_solve_t), intent(inout) :: self
        type(reduced_layout_t), intent(in) :: lay
        real(dp), intent(in) :: r(:)
        integer :: c, e, l, mm
        mm = self%order_m
        associate (w => self%w, end_rhs => self%end_rhs)
            do c = 1, self%n
                w(c) = dot_product(self%last_row, self%dz(c, :)) / self%h
            end do
            do l = 1, self%m
                end_rhs(self%band_position(l)) = -r(lay%v_row(l))
            end do
            do e = 1, size(lay%phi_rows)
                associate (pos => self%band_position(lay%phi_rows(e)))
                    end_rhs(pos) = end_rhs(pos) + self%pv(e, mm) * w(lay%phi_cols(e)) + &
                        self%kv(e) * self%dz(lay%phi_cols(e), mm)
                end associate
            end do
            call self%ends%solve(end_rhs)
            do l = 1, self%m
                self%dmu(l, mm) = end_rhs(self%band_position(l))
            end do
        end associate
    end subroutine end_multipliers

end module holosym_reduced_multipliers
