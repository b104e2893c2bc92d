!> category: internal submodule (use holosym)
!! What differs between the integrator's two steps, the general scheme and the reduced
!! step, dispatched on `path_t`: the displacement nodes and the momentum jump of the
!! pending step, a copy of its unknowns (root verification sets candidates aside), its
!! acceptance and the dense output of the last accepted step. Everything else of the
!! integrator is written once for both.
submodule (holosym_integrator) holosym_step_paths
    implicit none

contains

    module subroutine path_node(self, q, i, node)
        class(constrained_integrator), intent(in) :: self
        real(wp), intent(in) :: q(:)
        integer, intent(in) :: i
        real(wp), intent(out) :: node(:)
        if (self%pending%step == STEP_GENERAL) then
            call self%scheme%solution_node(self%x_work, i, node)
        else
            node = q
            if (i > 0) node = q + self%reduced%x(self%reduced%scheme%layout%z_col(:, i))
        end if
    end subroutine path_node

    module function path_momentum_jump(self, p, h) result(jump)
        class(constrained_integrator), intent(in) :: self
        real(wp), intent(in) :: p(:), h
        real(wp) :: jump
        if (self%pending%step == STEP_GENERAL) then
            jump = self%scheme%momentum_jump(self%x_work, self%dp_work)
        else
            jump = self%reduced%scheme%momentum_jump(self%reduced%x, p, self%dp_work, h)
        end if
    end function path_momentum_jump

    module subroutine path_solution(self, x)
        class(constrained_integrator), intent(in) :: self
        real(wp), allocatable, intent(out) :: x(:)
        if (self%pending%step == STEP_GENERAL) then
            x = self%x_work
        else
            x = self%reduced%x
        end if
    end subroutine path_solution

    module subroutine path_restore_solution(self, x)
        class(constrained_integrator), intent(inout) :: self
        real(wp), intent(in) :: x(:)
        if (self%pending%step == STEP_GENERAL) then
            self%x_work = x
        else
            self%reduced%x = x
        end if
    end subroutine path_restore_solution

    module subroutine path_accept(self, sys, q, p, h, rebind)
        class(constrained_integrator), intent(inout) :: self
        class(constrained_hamiltonian), intent(in), target :: sys
        real(wp), intent(in) :: q(:), p(:), h
        logical, intent(in) :: rebind
        if (self%pending%step == STEP_GENERAL) then
            if (rebind) call self%scheme%set_step(sys, q, p, h)
            call self%scheme%node_values(self%x_work, self%last_info%lambda)
            self%last_x = self%x_work
        else
            call self%reduced%accept(q, h)
            call self%reduced%scheme%multipliers(self%reduced%last_x, h, self%last_info%lambda)
        end if
        self%path%last = self%pending%step
    end subroutine path_accept

    module subroutine path_dense(self, tau, q, p, lambda)
        class(constrained_integrator), intent(in) :: self
        real(wp), intent(in) :: tau
        real(wp), intent(out) :: q(:), p(:), lambda(:)
        if (self%path%last == STEP_GENERAL) then
            call self%scheme%dense(self%last_x, self%last_qa, self%last_pa, self%last_h, &
                                   tau, q, p, lambda)
        else
            call self%reduced%scheme%dense(self%reduced%last_x, self%last_qa, self%last_h, &
                                           tau, q, p, lambda)
        end if
    end subroutine path_dense

end submodule holosym_step_paths
