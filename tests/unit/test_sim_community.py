"""The agent's variable store: post_many is post, one pair after another."""

from uhrisim.sim.community import Community


def test_post_many_posts_like_post_one_by_one() -> None:
    pairs = [("NAV_X", 1.5), ("DEPLOY", True), ("COUNT", 3), ("NODE_REPORT", "NAME=a"),
             ("NAV_X", -2.0), ("NODE_REPORT", "NAME=b"), ("RETURN", False), ("MODE", "go")]
    one, many = Community("rov"), Community("rov")
    early = (one.mailbox(), many.mailbox())
    one.post("NAV_Y", 0.25, 0.0, "start")
    many.post("NAV_Y", 0.25, 0.0, "start")
    late = (one.mailbox(), many.mailbox())
    for var, value in pairs:
        one.post(var, value, 2.5, "helm")
    many.post_many(pairs, 2.5, "helm")
    assert one.values() == many.values() and list(one.values()) == list(many.values())
    for a, b in (early, late):
        mail_a, mail_b = a.drain(), b.drain()
        assert mail_a == mail_b and list(mail_a) == list(mail_b)
    assert one.take_log() == many.take_log()
    assert many.values()["DEPLOY"] == "true" and many.values()["COUNT"] == 3.0
