"""The task panels, one module each: sample_face (*Sample face*), compare (*Compare strategies*),
plan_part (*Plan part*); base holds what they share (:class:`base.BackgroundRunPanel`: one poll of
the background run, the time estimate, the status line), fields the fields and the values they
show by the API's argument names."""
