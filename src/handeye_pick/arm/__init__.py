"""The arm's model (docs/arm-model.md): Universal Robots' DH kinematics and a solid per link
(``models``), forward kinematics and the link solids' poses for a batch of joint vectors
(``kinematics``), the joint angles along a move (``path``), how far a link can move for a joint
step (``bound``) and the connect-time checks that the model is the arm on the controller
(``agree``). numpy only; no python-fcl, no controller."""
